//! The GPU context: instance, adapter choice, device and queue.
//!
//! Adapter choice follows wgpu's environment variables: `WGPU_BACKEND` (`vulkan`, `gl`, `metal`,
//! `dx12`, comma separated) picks the backends, `WGPU_ADAPTER_NAME` picks the first adapter whose name
//! contains the given text (case-insensitive). Timestamp queries are turned on where the adapter has
//! them; [`GpuContext::timestamps`] says whether they are.

use std::sync::{Arc, Mutex};

use bevy_ecs::prelude::*;

/// What went wrong while opening the GPU.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found (backends {backends:?}{name_note}; adapters seen: {seen}). Install a Vulkan driver: on \
         Debian or Ubuntu `apt-get install mesa-vulkan-drivers libvulkan1` gives the software driver lavapipe (or run \
         `make test`, which installs it); on a machine with a GPU install its vendor's driver. WGPU_BACKEND and \
         WGPU_ADAPTER_NAME choose among several."
    )]
    /// No adapter of the allowed backends (and name, if `WGPU_ADAPTER_NAME` asks for one) was found.
    NoAdapter {
        /// The backends searched (`WGPU_BACKEND`, or wgpu's primary ones).
        backends: wgpu::Backends,
        /// `", name containing '…'"` when `WGPU_ADAPTER_NAME` narrowed the search, else empty.
        name_note: String,
        /// Every adapter found, as `name (backend)`, comma separated; `"none"` if there were none.
        seen: String,
    },
    /// The chosen adapter would not open a device with the features and limits asked for.
    #[error("the GPU adapter '{adapter}' refused to create a device: {source}")]
    RequestDevice {
        /// The adapter's name.
        adapter: String,
        /// wgpu's reason.
        #[source]
        source: wgpu::RequestDeviceError,
    },
}

/// How to react to wgpu validation errors that are not caught by an error scope.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ValidationErrors {
    /// Log them (applications).
    #[default]
    Log,
    /// Panic (tests: a validation error fails the test).
    Panic,
}

/// Options for [`GpuContext::new`].
#[derive(Default)]
pub struct GpuOptions<'a> {
    /// What an uncaught wgpu validation error does: log (default) or panic.
    pub validation_errors: ValidationErrors,
    /// A surface the adapter must be able to present to (windowed runner).
    pub compatible_surface: Option<&'a wgpu::Surface<'a>>,
    /// An instance to reuse (the one the surface was created from).
    pub instance: Option<wgpu::Instance>,
    /// Limits to ask for instead of the adapter's own (each clamped to the adapter's): tests of
    /// scenes over a small GPU's limits.
    pub limits: Option<wgpu::Limits>,
    /// Ask for subgroup operations ([`wgpu::Features::SUBGROUP`]) where the adapter has them
    /// ([`GpuContext::subgroups`] says whether it did): the trace bench's postponing kernels
    /// (`lab/shaders/bench_trace_subgroup.wgsl`). Off by default: on Vulkan the feature lets the
    /// driver pick every pipeline's subgroup size (`ALLOW_VARYING_SUBGROUP_SIZE`), which the
    /// engine's own shaders do not need.
    pub subgroups: bool,
}

/// The device everything renders with. Cheap to clone (wgpu handles are reference counted).
#[derive(Resource, Clone)]
pub struct GpuContext {
    /// The wgpu instance the adapter came from (surfaces of the windowed runner are made with it).
    pub instance: wgpu::Instance,
    /// The adapter chosen (see the module docs for how).
    pub adapter: wgpu::Adapter,
    /// The device: every buffer, texture and pipeline is created on it.
    pub device: wgpu::Device,
    /// The device's queue: uploads and command submission.
    pub queue: wgpu::Queue,
    /// Whether GPU timestamps can be written between commands (per-pass timing spans).
    pub timestamps: bool,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period: f32,
    /// Whether shaders may use subgroup operations ([`wgpu::Features::SUBGROUP`]): asked for with
    /// [`GpuOptions::subgroups`] and offered by the adapter.
    pub subgroups: bool,
    /// Why the device was lost, once it is (see [`GpuContext::lost`]).
    lost: Arc<Mutex<Option<String>>>,
}

impl GpuContext {
    /// Creates an instance from the environment and opens the chosen adapter.
    pub fn new(options: GpuOptions<'_>) -> Result<Self, GpuError> {
        let instance = options.instance.clone().unwrap_or_else(Self::create_instance);
        pollster::block_on(Self::open(instance, options))
    }

    /// The instance every context of this process uses: backends from `WGPU_BACKEND`.
    ///
    /// Debug labels and driver validation layers are off unless `WGPU_DEBUG=1` / `WGPU_VALIDATION=1`
    /// ask for them (wgpu's own validation is always on): lavapipe 22.3 crashes on debug labels.
    pub fn create_instance() -> wgpu::Instance {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        desc.flags = wgpu::InstanceFlags::empty().with_env();
        desc.backend_options = desc.backend_options.with_env();
        wgpu::Instance::new(desc)
    }

    async fn open(instance: wgpu::Instance, options: GpuOptions<'_>) -> Result<Self, GpuError> {
        let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let wanted_name = std::env::var("WGPU_ADAPTER_NAME").ok().filter(|s| !s.is_empty());
        let adapters = instance.enumerate_adapters(backends).await;
        let seen: Vec<String> = adapters.iter().map(|a| format!("{} ({:?})", a.get_info().name, a.get_info().backend)).collect();
        let compatible = |a: &wgpu::Adapter| options.compatible_surface.is_none_or(|s| a.is_surface_supported(s));
        let adapter = match &wanted_name {
            Some(name) => {
                let lower = name.to_lowercase();
                adapters.into_iter().find(|a| compatible(a) && a.get_info().name.to_lowercase().contains(&lower))
            }
            None => instance
                .request_adapter(&wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::HighPerformance,
                    force_fallback_adapter: false,
                    compatible_surface: options.compatible_surface,
                    apply_limit_buckets: false,
                })
                .await
                .ok(),
        };
        let Some(adapter) = adapter else {
            return Err(GpuError::NoAdapter {
                backends,
                name_note: wanted_name.map(|n| format!(", name containing '{n}'")).unwrap_or_default(),
                seen: if seen.is_empty() { "none".into() } else { seen.join(", ") },
            });
        };
        let timestamp_features = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        let mut wanted = timestamp_features;
        if options.subgroups {
            wanted |= wgpu::Features::SUBGROUP;
        }
        let features = adapter.features() & wanted;
        let timestamps = features.contains(timestamp_features);
        let subgroups = features.contains(wgpu::Features::SUBGROUP);
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("engine_device"),
                required_features: features,
                required_limits: match &options.limits {
                    Some(wanted) => wanted.clone().or_worse_values_from(&adapter.limits()),
                    None => adapter.limits(),
                },
                ..Default::default()
            })
            .await
            .map_err(|source| GpuError::RequestDevice { adapter: adapter.get_info().name, source })?;
        let lost = Arc::new(Mutex::new(None));
        {
            let lost = lost.clone();
            device.set_device_lost_callback(move |reason, message| {
                log::error!("the GPU device was lost ({reason:?}): {message}");
                *lost.lock().unwrap_or_else(|e| e.into_inner()) = Some(format!("{reason:?}: {message}"));
            });
        }
        // Once the device is lost every call on it fails: those errors are its consequence, not
        // bugs, and are logged even in tests.
        let after_loss = lost.clone();
        let is_lost = move || after_loss.lock().unwrap_or_else(|e| e.into_inner()).is_some();
        match options.validation_errors {
            ValidationErrors::Panic => device.on_uncaptured_error(Arc::new(move |e| {
                if is_lost() {
                    log::warn!("wgpu error after the device was lost: {e}");
                } else {
                    panic!("wgpu error: {e}")
                }
            })),
            ValidationErrors::Log => device.on_uncaptured_error(Arc::new(|e| log::error!("wgpu error: {e}"))),
        }
        let timestamp_period = queue.get_timestamp_period();
        log::info!("GPU: {} ({:?}), timestamps: {timestamps}, subgroups: {subgroups}", adapter.get_info().name, adapter.get_info().backend);
        Ok(Self { instance, adapter, device, queue, timestamps, timestamp_period, subgroups, lost })
    }

    /// Adapter name, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)" or "NVIDIA H100 80GB HBM3".
    pub fn adapter_name(&self) -> String {
        self.adapter.get_info().name
    }

    /// Blocks until the GPU has finished all submitted work and callbacks have run.
    pub fn wait_idle(&self) {
        let _span = tracing::info_span!("wait_idle").entered();
        if let Err(e) = self.device.poll(wgpu::PollType::wait_indefinitely()) {
            log::error!("waiting for the GPU failed: {e}");
        }
    }

    /// Why the device was lost (driver reset, GPU removed, [`wgpu::Device::destroy`]), or `None`
    /// while it works. A lost device never comes back: the app's render stages stop
    /// ([`crate::app::GpuLost`]) and a runner that wants to go on opens a new context.
    pub fn lost(&self) -> Option<String> {
        self.lost.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// Destroys the device, as a driver reset would lose it, and waits until wgpu reports the loss
    /// (tests and the demo's fault injection).
    pub fn simulate_device_loss(&self) {
        self.device.destroy();
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }

    /// A context for tests (called through `testkit::gpu`): validation errors panic. Without an
    /// adapter the test is skipped: it returns `None` after a `skipped: no GPU adapter` line on
    /// standard error that the test harness does not capture, so a skip never reads as a pass;
    /// except in CI (`CI=true`), where a missing adapter is a failure.
    pub fn for_tests(test: &str) -> Option<Self> {
        Self::for_tests_with(test, GpuOptions::default())
    }

    /// [`GpuContext::for_tests`] with other options (validation errors still panic).
    pub fn for_tests_with(test: &str, options: GpuOptions<'_>) -> Option<Self> {
        match Self::new(GpuOptions { validation_errors: ValidationErrors::Panic, ..options }) {
            Ok(ctx) => Some(ctx),
            Err(e) if std::env::var("CI").is_ok_and(|v| v == "true") => panic!("{test}: CI=true and {e}"),
            Err(e) => {
                // Straight to the file descriptor: the harness captures `eprintln!` of passing tests.
                use std::io::Write as _;
                let _ = writeln!(std::io::stderr(), "{test}: skipped: no GPU adapter ({e})");
                None
            }
        }
    }
}
