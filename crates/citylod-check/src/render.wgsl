// citylod-check flat renderer. Vertices arrive in clip space (transformed and shaded on the CPU in f64),
// so the GPU only rasterizes, depth-tests (reverse-Z, greater wins) and writes colour and feature id.

struct VertexIn {
    @location(0) clip: vec4<f32>,
    @location(1) colour: vec4<f32>,
    @location(2) feature: u32,
}

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) colour: vec4<f32>,
    @location(1) @interpolate(flat) feature: u32,
}

struct FragmentOut {
    @location(0) colour: vec4<f32>,
    @location(1) feature: u32,
}

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.position = v.clip;
    out.colour = v.colour;
    out.feature = v.feature;
    return out;
}

@fragment
fn fs_main(v: VertexOut) -> FragmentOut {
    var out: FragmentOut;
    out.colour = v.colour;
    out.feature = v.feature;
    return out;
}
