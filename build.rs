//! Compiles every `glsl/*.comp` to SPIR-V with shaderc (linked against Debian's libshaderc-dev).
//! `#include "x.glsl"` resolves against `glsl/include/`. A shader error fails the build and
//! prints file:line.
//!
//! The integer `#define`s of each include (`#define NAME 12`) become Rust constants in a module
//! named after the file (`realcam::gpu::shaders::dof_tiles::ARGS_WORDS`), so buffer layouts and
//! indirect-argument offsets are written once, in GLSL, and shared.

use std::path::{Path, PathBuf};

fn main() {
    let glsl = Path::new("glsl");
    let include_dir = glsl.join("include");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo:rerun-if-changed=glsl");

    let mut names: Vec<String> = std::fs::read_dir(glsl)
        .expect("glsl/ exists")
        .filter_map(|e| e.ok())
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|n| n.ends_with(".comp"))
        .collect();
    names.sort();
    let mut includes: Vec<PathBuf> =
        std::fs::read_dir(&include_dir).into_iter().flatten().flatten().map(|e| e.path()).collect();
    includes.sort();
    let mut constants = String::new();
    for path in &includes {
        println!("cargo:rerun-if-changed={}", path.display());
        let (Some(stem), Ok(text)) = (path.file_stem().and_then(|s| s.to_str()), std::fs::read_to_string(path)) else {
            continue;
        };
        constants += &format!("/// The integer `#define`s of glsl/include/{stem}.glsl.\npub mod {stem} {{\n");
        for line in text.lines() {
            let mut words = line.split_whitespace();
            if let (Some("#define"), Some(name), Some(value)) = (words.next(), words.next(), words.next()) {
                let rest: Vec<&str> = words.collect();
                let trailing_ok = rest.is_empty() || rest[0].starts_with("//");
                if let (Ok(v), true) = (value.parse::<u32>(), trailing_ok) {
                    constants += &format!("    pub const {name}: u32 = {v};\n");
                }
            }
        }
        constants += "}\n";
    }

    let compiler = shaderc::Compiler::new().expect("shaderc compiler");
    let mut errors = Vec::new();
    let mut table =
        String::from("/// Every embedded shader: (name, SPIR-V bytes).\npub static ALL: &[(&str, &[u8])] = &[\n");
    for name in &names {
        let path = glsl.join(name);
        println!("cargo:rerun-if-changed={}", path.display());
        let source = std::fs::read_to_string(&path).expect("readable shader");
        let mut options = shaderc::CompileOptions::new().expect("shaderc options");
        options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_2 as u32);
        options.set_optimization_level(shaderc::OptimizationLevel::Performance);
        options.set_generate_debug_info();
        let inc = include_dir.clone();
        options.set_include_callback(move |requested, _kind, from, _depth| {
            let p = inc.join(requested);
            std::fs::read_to_string(&p)
                .map(|content| shaderc::ResolvedInclude { resolved_name: p.display().to_string(), content })
                .map_err(|e| format!("{from}: cannot include {requested}: {e}"))
        });
        let shown = format!("glsl/{name}");
        match compiler.compile_into_spirv(&source, shaderc::ShaderKind::Compute, &shown, "main", Some(&options)) {
            Ok(artifact) => {
                let stem = name.trim_end_matches(".comp");
                let spv = out.join(format!("{stem}.spv"));
                std::fs::write(&spv, artifact.as_binary_u8()).expect("write spv");
                table += &format!("    (\"{stem}\", include_bytes!(\"{}\")),\n", spv.display());
            }
            // shaderc's message already reads "glsl/name.comp:LINE: error: ..."
            Err(e) => errors.push(e.to_string()),
        }
    }
    if !errors.is_empty() {
        for e in &errors {
            for line in e.lines() {
                println!("cargo:warning={line}");
            }
        }
        eprintln!("{}", errors.join("\n"));
        std::process::exit(1);
    }
    table += "];\n";
    table += &constants;
    std::fs::write(out.join("shaders.rs"), table).expect("write shaders.rs");
}
