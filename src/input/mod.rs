//! The input stage: what a run is asked to do and over what. Case files and their checks, the
//! seeded sampler, the scene (configurations and the GPU's Scene struct), the target
//! integrals, the LTC tables, look-up table files as engines ship them (DDS, KTX2, OpenEXR,
//! `.npy`), and the names that messages and report files use.

pub mod case;
pub mod geometry;
pub mod ltc;
pub mod names;
pub mod render_scene;
pub mod sampler;
pub mod scene;
pub mod target;
pub mod texture;
pub mod texture_file;
