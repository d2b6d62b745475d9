//! The browser front end (wasm32 only): the container reader and the
//! reconstruction run here; H.264 is decoded by the page with WebCodecs
//! (exact, so the luma planes equal the native openh264 decode) and handed
//! in; the shared renderer draws into a canvas with WebGPU, or WebGL2 when
//! the browser has no WebGPU adapter.
//!
//! JavaScript sees two classes: [`Player`] (bytes in, positions out) and
//! [`View`] (a canvas, a camera, a colour mode), and the [`FrameMesh`]
//! values a player returns; `player.rs` is the decoder alone, `view.rs`
//! (the `render` feature) draws.

mod player;
#[cfg(feature = "render")]
mod view;

pub use player::{FrameMesh, Player};
#[cfg(feature = "render")]
pub use view::View;

use wasm_bindgen::prelude::*;

#[wasm_bindgen(start)]
pub fn start() {
    console_error_panic_hook::set_once();
}

/// Points from JavaScript's flat x, y, z arrays.
pub(crate) fn positions(flat: &[f32]) -> Vec<glam::Vec3> {
    flat.chunks_exact(3).map(|c| glam::Vec3::new(c[0], c[1], c[2])).collect()
}

pub(crate) fn js(e: impl std::fmt::Display) -> JsError {
    JsError::new(&e.to_string())
}
