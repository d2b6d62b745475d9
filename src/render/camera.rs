//! An orbit camera: yaw and pitch about a target, at a distance. Drag
//! rotates, the wheel or a pinch zooms, reset frames the bounds again.

use glam::{Mat4, Vec3};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbitCamera {
    pub target: Vec3,
    pub distance: f32,
    /// Radians about +y.
    pub yaw: f32,
    /// Radians above the horizon, kept inside ±89°.
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

impl OrbitCamera {
    /// Looks at a box from the front (+z), slightly above, far enough that
    /// the box fits the vertical field of view.
    pub fn framing(min: Vec3, max: Vec3) -> OrbitCamera {
        let fov_y = 40f32.to_radians();
        let radius = ((max - min).length() * 0.5).max(1e-6);
        OrbitCamera {
            target: (min + max) * 0.5,
            distance: radius / (fov_y * 0.5).sin() * 1.2,
            yaw: 0.0,
            pitch: 0.15,
            fov_y,
        }
    }

    /// Rotates by a drag of (dx, dy) in units of the viewport height.
    pub fn drag(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * std::f32::consts::PI;
        self.pitch = (self.pitch + dy * std::f32::consts::PI).clamp(-1.553, 1.553);
    }

    /// Zooms by `factor` (> 1 moves away), within sane limits.
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.distance = (self.distance * factor).clamp(1e-4, 1e6);
        }
    }

    pub fn eye(&self) -> Vec3 {
        let dir = Vec3::new(self.pitch.cos() * self.yaw.sin(), self.pitch.sin(), self.pitch.cos() * self.yaw.cos());
        self.target + dir * self.distance
    }

    /// Clip-from-world for a viewport of `aspect` = width / height (wgpu's
    /// 0..1 depth range).
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let near = self.distance * 0.01;
        let far = self.distance * 10.0;
        // Right-handed, depth 0..1 and y up in clip space: the D3D convention wgpu shares.
        glam::camera::rh::proj::directx::perspective(self.fov_y, aspect.max(1e-3), near, far)
            * glam::camera::rh::view::look_at_mat4(self.eye(), self.target, Vec3::Y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_puts_the_box_in_view_and_drag_keeps_the_distance() {
        let mut c = OrbitCamera::framing(Vec3::splat(-1.0), Vec3::splat(1.0));
        let m = c.view_proj(1.0);
        for corner in [Vec3::splat(-1.0), Vec3::splat(1.0), Vec3::new(1.0, -1.0, 1.0)] {
            let p = m.project_point3(corner);
            assert!(p.x.abs() <= 1.0 && p.y.abs() <= 1.0 && (0.0..=1.0).contains(&p.z), "{corner} -> {p}");
        }
        let d = c.eye().distance(c.target);
        c.drag(0.3, 2.0);
        assert!((c.eye().distance(c.target) - d).abs() < 1e-4 && c.pitch < 1.56);
        c.zoom(2.0);
        assert!((c.distance - 2.0 * d).abs() < 1e-3);
    }
}
