#[allow(dead_code)]
pub mod controller;
#[allow(dead_code)]
pub mod level;
#[allow(dead_code)]
pub mod navmesh;
