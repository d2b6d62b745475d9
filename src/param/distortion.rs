//! Distortion of a parameterization, per face from the singular values
//! σ1 ≥ σ2 of the Jacobian of the affine map from the surface triangle to its
//! image, after scaling the image to the surface's total area. Conformal
//! (angle) distortion is σ1/σ2 (1 when angles are kept); area distortion is
//! σ1·σ2 (1 when areas are kept; below 1 means the face gets fewer samples
//! than its share). Statistics are weighted by surface area.

use glam::{DVec2, DVec3};

#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Distortion {
    /// Area-weighted mean of σ1/σ2.
    pub conformal_mean: f64,
    /// 95th percentile (by area) of σ1/σ2.
    pub conformal_p95: f64,
    pub conformal_max: f64,
    /// Area-weighted mean of |ln(σ1 σ2)|.
    pub area_log_mean: f64,
    /// 1st and 99th percentile (by area) of σ1 σ2.
    pub area_p01: f64,
    pub area_p99: f64,
    pub area_min: f64,
    pub area_max: f64,
    /// L2 stretch of the inverse map, square to surface (Sander, Snyder,
    /// Gortler, Hoppe 2001): the area-weighted RMS of sqrt((1/σ1² + 1/σ2²)/2);
    /// 1 for an isometry, large when parts of the surface get few samples.
    pub stretch_l2: f64,
    /// Faces whose image is reversed or has no area ...
    pub flipped_faces: usize,
    /// ... and their share of the surface's area (0 to 1): what the grid
    /// resamples from the neighbouring samples instead of mapping.
    pub flipped_area: f64,
}

fn weighted_percentile(v: &mut [(f64, f64)], q: f64) -> f64 {
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = v.iter().map(|x| x.1).sum();
    let mut acc = 0.0;
    for &(x, w) in v.iter() {
        acc += w;
        if acc >= q * total {
            return x;
        }
    }
    v.last().map_or(0.0, |x| x.0)
}

/// Singular values (σ1, σ2) and determinant sign of the map from the
/// triangle `p` to `q`, with `scale` dividing the image's area.
pub fn face_singular_values(p: [DVec3; 3], q: [DVec2; 3], scale: f64) -> (f64, f64, f64) {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let l1 = e1.length();
    let x = e1 / l1.max(1e-300);
    let n = e1.cross(e2);
    let y = n.cross(e1).normalize_or_zero();
    let (a, b) = (DVec2::new(l1, 0.0), DVec2::new(e2.dot(x), e2.dot(y)));
    let (qa, qb) = ((q[1] - q[0]) / scale.sqrt(), (q[2] - q[0]) / scale.sqrt());
    // J [a b] = [qa qb]  =>  J = [qa qb] [a b]^-1
    let det_p = a.x * b.y - a.y * b.x;
    if det_p.abs() < 1e-300 {
        return (0.0, 0.0, 0.0);
    }
    let inv = [[b.y / det_p, -b.x / det_p], [-a.y / det_p, a.x / det_p]];
    let j = [
        [qa.x * inv[0][0] + qb.x * inv[1][0], qa.x * inv[0][1] + qb.x * inv[1][1]],
        [qa.y * inv[0][0] + qb.y * inv[1][0], qa.y * inv[0][1] + qb.y * inv[1][1]],
    ];
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    let fro2 = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
    // σ1² + σ2² = ‖J‖², σ1 σ2 = |det J|.
    let disc = (fro2 * fro2 - 4.0 * det * det).max(0.0).sqrt();
    let s1 = ((fro2 + disc) / 2.0).sqrt();
    let s2 = ((fro2 - disc) / 2.0).max(0.0).sqrt();
    (s1, s2, det.signum())
}

/// Area of a surface triangle.
pub fn surface_area(pos: &[DVec3], f: &[u32; 3]) -> f64 {
    0.5 * (pos[f[1] as usize] - pos[f[0] as usize]).cross(pos[f[2] as usize] - pos[f[0] as usize]).length()
}

/// Signed area of a triangle in the plane.
pub fn signed_area(q: [DVec2; 3]) -> f64 {
    0.5 * (q[1] - q[0]).perp_dot(q[2] - q[0])
}

/// Total image area over total surface area: divides image areas so that
/// σ1 σ2 = 1 means a face gets exactly its share.
fn image_scale(faces: &[[u32; 3]], pos: &[DVec3], face_uv: &impl Fn(usize) -> [DVec2; 3]) -> f64 {
    let total3: f64 = faces.iter().map(|f| surface_area(pos, f)).sum();
    let total2: f64 = (0..faces.len()).map(|f| signed_area(face_uv(f))).sum();
    (total2 / total3).abs().max(1e-300)
}

/// Each face's area ratio σ1 σ2 (image area over surface area, the image
/// scaled to the surface's total area; 0 where the surface triangle has no
/// area), from the areas alone: what the area passes need of a map, without
/// the singular values [`measure`] takes.
pub fn area_ratios(area3: &[f64], face_uv: impl Fn(usize) -> [DVec2; 3]) -> Vec<f64> {
    let uv_area: Vec<f64> = (0..area3.len()).map(|f| signed_area(face_uv(f))).collect();
    let scale = (uv_area.iter().sum::<f64>() / area3.iter().sum::<f64>()).abs().max(1e-300);
    uv_area.iter().zip(area3).map(|(&q, &a)| if a > 0.0 { q / (scale * a) } else { 0.0 }).collect()
}

/// Per-face area stretch of the inverse map (square to surface), 1/sqrt(σ1 σ2)
/// with the image scaled to the surface's total area: above 1 where a face
/// gets less than its share of the square, infinite where its image is
/// reversed or flat. (Yoshizawa et al. use the L2
/// stretch; on samba that leaves 1 % of the surface with under a tenth of
/// its share and doubles the angle distortion, so we measure area alone.)
pub fn face_stretch(ratios: &[f64]) -> Vec<f64> {
    ratios.iter().map(|&r| if r > 0.0 { 1.0 / r.sqrt() } else { f64::INFINITY }).collect()
}

/// The two figures of [`measure`] an area pass is judged by.
pub struct AreaSummary {
    /// Area-weighted mean of |ln(σ1 σ2)|.
    pub area_log_mean: f64,
    /// Faces whose image is reversed or has no area.
    pub flipped_faces: usize,
}

/// [`AreaSummary`] of the map `face_uv` of faces with 3D areas `area3`.
pub fn area_summary(area3: &[f64], ratios: &[f64], face_uv: impl Fn(usize) -> [DVec2; 3]) -> AreaSummary {
    let total3: f64 = area3.iter().sum();
    let log_sum: f64 = ratios.iter().zip(area3).map(|(&r, &w)| r.abs().max(1e-12).ln().abs() * w).sum();
    let flipped_faces = (0..area3.len()).filter(|&f| signed_area(face_uv(f)) <= 0.0).count();
    AreaSummary { area_log_mean: log_sum / total3, flipped_faces }
}

/// Measures the map `uv` (per face, as the face sees it) of a surface.
pub fn measure(faces: &[[u32; 3]], pos: &[DVec3], face_uv: impl Fn(usize) -> [DVec2; 3]) -> Distortion {
    let area3 = |f: &[u32; 3]| surface_area(pos, f);
    let total3: f64 = faces.iter().map(area3).sum();
    let scale = image_scale(faces, pos, &face_uv);
    let mut conf = Vec::with_capacity(faces.len());
    let mut area = Vec::with_capacity(faces.len());
    let mut d = Distortion { area_min: f64::INFINITY, ..Default::default() };
    for (fi, f) in faces.iter().enumerate() {
        let w = area3(f);
        let (s1, s2, _) = face_singular_values(f.map(|i| pos[i as usize]), face_uv(fi), scale);
        // The image's orientation, which is the Jacobian's sign wherever
        // the surface triangle has area, and still defined where it has none.
        if signed_area(face_uv(fi)) <= 0.0 {
            d.flipped_faces += 1;
        }
        let k = if s2 > 0.0 { s1 / s2 } else { f64::INFINITY };
        let a = s1 * s2;
        conf.push((k, w));
        area.push((a, w));
        d.conformal_mean += k.min(1e6) * w;
        let st = if s2 > 0.0 { 0.5 * (1.0 / (s1 * s1) + 1.0 / (s2 * s2)) } else { 1e300 };
        d.stretch_l2 += st.min(1e300) * w;
        d.area_log_mean += a.max(1e-12).ln().abs() * w;
        d.conformal_max = d.conformal_max.max(k);
        d.area_min = d.area_min.min(a);
        d.area_max = d.area_max.max(a);
    }
    d.conformal_mean /= total3;
    d.stretch_l2 = (d.stretch_l2 / total3).sqrt();
    d.area_log_mean /= total3;
    d.conformal_p95 = weighted_percentile(&mut conf, 0.95);
    d.area_p01 = weighted_percentile(&mut area, 0.01);
    d.area_p99 = weighted_percentile(&mut area, 0.99);
    d
}
