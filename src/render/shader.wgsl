// The grid surface (or the input's own mesh): Lambert shading with a head
// light, coloured grey, by a scalar (λ, H or error) through a blue–white–red
// map, or by the input's base colour and texture.

struct Uniforms {
    view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    // x: scalar low, y: scalar high, z: 1 when the scalar colours the surface
    scalar: vec4<f32>,
    // rgb: the base colour factor; w: 1 when it and the texture colour the surface
    tint: vec4<f32>,
};

@group(0) @binding(0) var<uniform> u: Uniforms;
@group(0) @binding(1) var base_texture: texture_2d<f32>;
@group(0) @binding(2) var base_sampler: sampler;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) value: f32,
    @location(3) uv: vec2<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) value: f32,
    @location(3) uv: vec2<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var o: VertexOut;
    o.clip = u.view_proj * vec4<f32>(v.position, 1.0);
    o.world = v.position;
    o.normal = v.normal;
    o.value = v.value;
    o.uv = v.uv;
    return o;
}

fn diverging(t: f32) -> vec3<f32> {
    let blue = vec3<f32>(0.23, 0.30, 0.75);
    let white = vec3<f32>(0.87, 0.87, 0.87);
    let red = vec3<f32>(0.71, 0.02, 0.15);
    let s = clamp(t, 0.0, 1.0);
    if (s < 0.5) {
        return mix(blue, white, s * 2.0);
    }
    return mix(white, red, s * 2.0 - 1.0);
}

@fragment
fn fs_main(i: VertexOut) -> @location(0) vec4<f32> {
    let to_eye = normalize(u.eye.xyz - i.world);
    var n = normalize(i.normal);
    // Two-sided: the grid's seams can show either side.
    if (dot(n, to_eye) < 0.0) {
        n = -n;
    }
    let diffuse = max(dot(n, to_eye), 0.0);
    // Sampled in uniform control flow, used only when the tint says so.
    let texel = textureSample(base_texture, base_sampler, i.uv).rgb;
    var base = vec3<f32>(0.80, 0.76, 0.70);
    if (u.tint.w > 0.5) {
        base = texel * u.tint.rgb;
    }
    if (u.scalar.z > 0.5) {
        let span = max(u.scalar.y - u.scalar.x, 1e-20);
        base = diverging((i.value - u.scalar.x) / span);
    }
    let c = base * (0.25 + 0.75 * diffuse);
    return vec4<f32>(c, 1.0);
}
