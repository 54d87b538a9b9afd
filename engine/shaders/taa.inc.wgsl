// The temporal anti-aliasing's settings, shared by its two passes (`taa` and `taa_output`); the
// host's mirror is `engine::render::taa::TaaParams`.

struct TaaParams {
    // Most samples a history pixel averages; past it the running mean is an exponential one.
    max_samples: f32,
    // 0: no history (the first frame, a camera cut or a new size): the frame is taken as it is.
    history_valid: u32,
    // Sharpening of the output (pass taa_output), 0–1.
    sharpness: f32,
    _pad: u32,
}
