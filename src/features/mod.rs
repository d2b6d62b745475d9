//! Features of an unregistered capture (every frame its own mesh), as the
//! seed paper builds its conformal geometry videos from one (section 4):
//!
//! - [`capture`]: the capture's frames, each its own mesh;
//! - [`hks`]: the heat kernel signature, from the Laplacian's low
//!   eigenpairs;
//! - [`nearest`]: a frame's vertices nearest another's, to start the
//!   next frame's eigenpairs from the last's;
//! - [`detect`]: its local maxima at a short diffusion time, the body's
//!   extremities;
//! - [`track`]: features matched between adjacent frames into tracks;
//! - [`tracking`]: a capture's features found on every frame and tracked;
//! - [`jumps`]: frames whose grid jumps, found by its speed;
//! - [`outliers`]: frames whose grid lies far from their own mesh,
//!   rebuilt from their neighbours;
//! - [`lids`]: the grid faces over a capture's holes, left out of the
//!   grid mesh it comes back as;
//! - [`register`]: every frame mapped onto the grid with four tracked
//!   features as the map's cones: a registered motion;
//! - [`report`]: what the registration found;
//! - [`follow`]: each frame's cut where the previous frame's ran;
//! - [`frame_map`]: one frame mapped with four tracked features as its
//!   cones;
//! - [`handover`]: each piece of a capture going on where the last one
//!   left off (its cones, its cut, its grid's turn);
//! - [`segments`]: stretches of a capture registered each with its own
//!   tracks (where the topology changes, every random-access interval, and
//!   where a stretch's tracks or maps fail);
//! - [`smooth`]: the registered grid smoothed in time along the surface;
//! - [`store`]: where a registration's frames are kept, in memory or
//!   spilled to a temporary file;
//! - [`symmetry`]: the square's turns, which take one frame's map to
//!   another's;
//! - [`diagonals`]: which of the square's turns lays the grid's diagonals
//!   the better way across a piece's frames.

pub mod capture;
pub mod cones;
pub mod detect;
pub mod diagonals;
pub mod follow;
pub mod frame_map;
pub mod handover;
pub mod hks;
pub mod jumps;
pub mod lids;
pub mod nearest;
pub mod outliers;
pub mod register;
pub mod report;
pub mod segments;
pub mod smooth;
pub mod store;
pub mod symmetry;
pub mod track;
pub mod tracking;
