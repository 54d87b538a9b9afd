//! Why a volume's settings cannot be used ([`DdgiSettingsError`]).

/// Why a volume cannot be used. The volume is left out (no indirect light from it) and the error
/// is logged with its entity.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DdgiSettingsError {
    /// A setting of the [`DdgiVolume`](super::DdgiVolume) is out of its range.
    #[error("DdgiVolume.{field} = {value}: {reason}")]
    Invalid {
        /// The field, e.g. `hysteresis`.
        field: &'static str,
        /// What it holds, as `Debug` prints it.
        value: String,
        /// Why it is out of range, e.g. `must be between 0 and 1`.
        reason: &'static str,
    },
    /// A setting of the [`crate::DdgiCascades`] is out of its range.
    #[error("DdgiCascades.{field} = {value}: {reason}")]
    InvalidCascades {
        /// The field, e.g. `count`.
        field: &'static str,
        /// What it holds.
        value: String,
        /// Why it is out of range, e.g. `must be finite and positive`.
        reason: &'static str,
    },
    /// The volume needs a texture or buffer larger than the adapter allows: fewer probes, rays or
    /// map texels fit.
    #[error("DdgiVolume: the {what} needs {needed} {unit}, over the adapter's limit of {limit}")]
    OverLimit {
        /// The texture or buffer, e.g. `probe atlas` or
        /// `per-ray buffer (probes × rays_per_probe × 16 bytes)`.
        what: &'static str,
        /// Its size, in `unit`s.
        needed: u64,
        /// The adapter's largest, in `unit`s.
        limit: u64,
        /// `bytes` for a buffer, `texels of height` for an atlas.
        unit: &'static str,
    },
    /// The volume has no bounds of its own and the scene no geometry to fit them to.
    #[error("DdgiVolume.bounds = None and the scene has no geometry to take bounds from")]
    NoBounds,
}

/// The error for `field` holding `value`, out of range for `reason`.
pub(super) fn invalid(field: &'static str, value: impl std::fmt::Debug, reason: &'static str) -> DdgiSettingsError {
    DdgiSettingsError::Invalid { field, value: format!("{value:?}"), reason }
}
