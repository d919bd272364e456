//! SPIR-V compiled from `glsl/` by build.rs (shaderc), embedded in the binary.

include!(concat!(env!("OUT_DIR"), "/shaders.rs"));

/// The SPIR-V of the shader `glsl/<name>.comp`.
pub fn spirv(name: &str) -> Result<&'static [u8], super::GpuError> {
    ALL.iter().find(|(n, _)| *n == name).map(|(_, s)| *s).ok_or_else(|| super::GpuError::NoShader(name.to_string()))
}
