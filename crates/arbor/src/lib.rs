//! arbor: a Whitted-style ray tracer built around the scene structures and
//! acceleration structures of Cornell's "Ray Tracing II".
pub mod mesh;
