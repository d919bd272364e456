//! Compiles every `glsl/**/*.comp` to SPIR-V with shaderc (linked against Debian's libshaderc-dev):
//! the shaders sit in one folder per effect (`glsl/dof/`, `glsl/flare/`, ...), each named by its
//! file stem, which must be unique across the folders (the build fails otherwise).
//! `#include "x.glsl"` resolves against `glsl/include/`. A shader error fails the build and
//! prints file:line.
//!
//! A shader may also be compiled a second time with a macro defined, as a shader of its own: a
//! line `// variant <name>: <MACRO>` in its source (e.g. a fallback for devices without subgroup
//! operations, whose SPIR-V must not even declare their capability).
//!
//! The integer `#define`s of each include (`#define NAME 12`) become Rust constants in a module
//! named after the file (`realcam::gpu::shaders::dof_tiles::ARGS_WORDS`), so buffer layouts and
//! indirect-argument offsets are written once, in GLSL, and shared.

use std::path::{Path, PathBuf};

fn main() {
    let glsl = Path::new("glsl");
    let include_dir = glsl.join("include");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    // Cargo scans a folder named here recursively: a shader added to any glsl/ folder rebuilds.
    println!("cargo:rerun-if-changed=glsl");

    // Every .comp under glsl/ (its path relative to glsl/), sorted.
    let mut names: Vec<PathBuf> = Vec::new();
    find_shaders(glsl, Path::new(""), &mut names);
    names.sort();
    let mut stems: Vec<&str> = names.iter().map(|n| stem_of(n)).collect();
    stems.sort_unstable();
    if let Some(w) = stems.windows(2).find(|w| w[0] == w[1]) {
        eprintln!("two shaders are named {}: shader names (file stems) must be unique under glsl/", w[0]);
        std::process::exit(1);
    }
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
    // The modules' names so far: a variant may take neither one of them nor a shader's stem.
    let mut built: Vec<String> = Vec::new();
    let mut table =
        String::from("/// Every embedded shader: (name, SPIR-V bytes).\npub static ALL: &[(&str, &[u8])] = &[\n");
    for name in &names {
        let path = glsl.join(name);
        println!("cargo:rerun-if-changed={}", path.display());
        let source = std::fs::read_to_string(&path).expect("readable shader");
        let shown = format!("glsl/{}", name.display());
        let mut builds = vec![(stem_of(name).to_string(), None)];
        builds.extend(variants(&source));
        for (stem, define) in builds {
            if built.contains(&stem) || (define.is_some() && stems.contains(&stem.as_str())) {
                errors.push(format!("{shown}: a second shader is named {stem}"));
            }
            built.push(stem.clone());
            match compile(&compiler, &include_dir, &source, &shown, define.as_deref()) {
                Ok(spirv) => {
                    let spv = out.join(format!("{stem}.spv"));
                    std::fs::write(&spv, spirv).expect("write spv");
                    table += &format!("    (\"{stem}\", include_bytes!(\"{}\")),\n", spv.display());
                }
                // shaderc's message already reads "glsl/effect/name.comp:LINE: error: ..."
                Err(e) => errors.push(e),
            }
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

/// The variants a shader's source declares: `// variant <name>: <MACRO>` lines, as (name, macro).
fn variants(source: &str) -> Vec<(String, Option<String>)> {
    source
        .lines()
        .filter_map(|line| line.trim().strip_prefix("// variant "))
        .filter_map(|rest| rest.split_once(':'))
        .map(|(name, define)| (name.trim().to_string(), Some(define.trim().to_string())))
        .collect()
}

/// One shader's SPIR-V, with `define` defined when given.
fn compile(
    compiler: &shaderc::Compiler,
    include_dir: &Path,
    source: &str,
    shown: &str,
    define: Option<&str>,
) -> Result<Vec<u8>, String> {
    let mut options = shaderc::CompileOptions::new().expect("shaderc options");
    if let Some(define) = define {
        options.add_macro_definition(define, None);
    }
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_2 as u32);
    options.set_optimization_level(shaderc::OptimizationLevel::Performance);
    options.set_generate_debug_info();
    let inc = include_dir.to_path_buf();
    options.set_include_callback(move |requested, _kind, from, _depth| {
        let p = inc.join(requested);
        std::fs::read_to_string(&p)
            .map(|content| shaderc::ResolvedInclude { resolved_name: p.display().to_string(), content })
            .map_err(|e| format!("{from}: cannot include {requested}: {e}"))
    });
    compiler
        .compile_into_spirv(source, shaderc::ShaderKind::Compute, shown, "main", Some(&options))
        .map(|artifact| artifact.as_binary_u8().to_vec())
        .map_err(|e| e.to_string())
}

/// Collects the `.comp` files under `root/dir` (paths relative to `root`), `include/` left out.
fn find_shaders(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) {
    let full = root.join(dir);
    let mut entries: Vec<_> = std::fs::read_dir(&full).expect("glsl/ exists").filter_map(|e| e.ok()).collect();
    entries.sort_by_key(|e| e.file_name());
    for entry in entries {
        let rel = dir.join(entry.file_name());
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            if rel != Path::new("include") {
                find_shaders(root, &rel, out);
            }
        } else if rel.extension().is_some_and(|e| e == "comp") {
            out.push(rel);
        }
    }
}

/// A shader's name: its file stem.
fn stem_of(path: &Path) -> &str {
    path.file_stem().and_then(|s| s.to_str()).expect("a shader file name is UTF-8")
}
