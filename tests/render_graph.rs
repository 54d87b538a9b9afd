//! Render graph: passes run in script order, passes whose outputs nobody reads are skipped, and
//! (on the GPU) only live passes record commands.

use std::sync::{Arc, Mutex};

use engine::graph::{BufferDesc, GpuTimer, RenderGraph, TextureDesc, TransientPool};

fn desc() -> TextureDesc {
    TextureDesc { width: 4, height: 4, format: wgpu::TextureFormat::Rgba8Unorm, usage: wgpu::TextureUsages::STORAGE_BINDING }
}

#[test]
fn passes_feeding_an_export_run_in_order_and_the_rest_are_culled() {
    let mut g = RenderGraph::new();
    let mut a = g.create_texture("a", desc());
    let mut b = g.create_texture("b", desc());
    let mut unused = g.create_texture("unused", desc());
    let mut out = g.create_texture("out", desc());
    {
        let mut p = g.add_pass("make_a");
        p.write(&mut a);
        p.render(|_| {});
    }
    {
        let mut p = g.add_pass("make_unused_from_a");
        p.read(&a);
        p.write(&mut unused);
        p.render(|_| {});
    }
    {
        let mut p = g.add_pass("make_b");
        p.read(&a);
        p.write(&mut b);
        p.render(|_| {});
    }
    {
        let mut p = g.add_pass("make_out");
        p.read(&b);
        p.write(&mut out);
        p.render(|_| {});
    }
    g.export(&out);
    assert_eq!(g.pass_labels(), ["make_a", "make_unused_from_a", "make_b", "make_out"]);
    assert_eq!(g.live_passes(), [true, false, true, true]);
}

#[test]
fn an_overwrite_ends_the_need_for_the_older_contents() {
    let mut g = RenderGraph::new();
    let mut t = g.create_texture("t", desc());
    let mut u = g.create_texture("u", desc());
    for label in ["first_write", "second_write"] {
        let mut p = g.add_pass(label);
        p.write(&mut t);
        p.render(|_| {});
    }
    {
        // A read-modify-write keeps what came before it alive.
        let mut p = g.add_pass("accumulate");
        p.read(&t);
        p.write(&mut t);
        p.render(|_| {});
    }
    {
        let mut p = g.add_pass("write_u");
        p.write(&mut u);
        p.render(|_| {});
    }
    g.export(&t);
    assert_eq!(g.live_passes(), [false, true, true, false]);
}

#[test]
fn nothing_exported_means_nothing_runs() {
    let mut g = RenderGraph::new();
    let mut b = g.create_buffer("b", BufferDesc { size: 16, usage: wgpu::BufferUsages::STORAGE });
    let mut p = g.add_pass("orphan");
    p.write(&mut b);
    p.render(|_| {});
    assert_eq!(g.live_passes(), [false]);
}

#[test]
fn only_live_passes_record_commands_on_the_gpu_and_report_their_time() {
    let Some(gpu) = testkit::gpu("only_live_passes_record_commands_on_the_gpu_and_report_their_time") else { return };
    let ran = Arc::new(Mutex::new(Vec::new()));
    let mut g = RenderGraph::new();
    let usage = wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
    let mut first = g.create_buffer("first", BufferDesc { size: 64, usage });
    let mut skipped = g.create_buffer("skipped", BufferDesc { size: 64, usage });
    let external =
        gpu.device.create_buffer(&wgpu::BufferDescriptor { label: Some("external"), size: 64, usage, mapped_at_creation: false });
    let mut ext = g.import_buffer("external", &external);
    for (label, write_skipped) in [("clear_first", false), ("clear_skipped", true)] {
        let log = ran.clone();
        let mut p = g.add_pass(label);
        let w = if write_skipped { p.write(&mut skipped) } else { p.write(&mut first) };
        p.render(move |ctx| {
            log.lock().unwrap().push(ctx.label.to_string());
            ctx.encoder.clear_buffer(ctx.buffer(w), 0, None);
        });
    }
    {
        let log = ran.clone();
        let mut p = g.add_pass("copy_out");
        let r = p.read(&first);
        let w = p.write(&mut ext);
        p.render(move |ctx| {
            log.lock().unwrap().push(ctx.label.to_string());
            ctx.encoder.copy_buffer_to_buffer(ctx.buffer(r), 0, ctx.buffer(w), 0, 64);
        });
    }
    g.export(&ext);
    let mut timer = GpuTimer::default();
    let mut report = g.execute(&gpu, &mut TransientPool::default(), Some(&mut timer));
    assert_eq!(*ran.lock().unwrap(), ["clear_first", "copy_out"]);
    let skipped: Vec<_> = report.passes.iter().filter(|p| !p.ran).map(|p| p.label.as_str()).collect();
    assert_eq!(skipped, ["clear_skipped"]);
    if let Some(times) = report.wait_for_timings(&gpu, &mut timer) {
        let labels: Vec<_> = times.iter().map(|(l, _)| l.as_str()).collect();
        assert_eq!(labels, ["clear_first", "copy_out"]);
        assert!(times.iter().all(|(_, ms)| ms.is_finite() && *ms >= 0.0), "{times:?}");
    }
}
