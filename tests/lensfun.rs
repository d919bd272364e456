//! The lensfun import against the installed database (Debian package liblensfun-data-v1,
//! /usr/share/lensfun/version_1 or $REALCAM_LENSFUN_DIR), the preset lens files made from it,
//! and the command line. Without the database these tests fail (they are not skipped): run
//! scripts/install-deps.sh.

use realcam::io::lens_file::{LensFile, LensTables};
use realcam::io::lensfun::{self, Database, ImportOptions, Imported};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The installed database, loaded once.
fn database() -> &'static Database {
    static DB: OnceLock<Database> = OnceLock::new();
    DB.get_or_init(|| {
        let dir = lensfun::database_dir(None);
        Database::load(&dir).unwrap_or_else(|e| {
            panic!(
                "these tests need lensfun's database ({}): {e}\n\
                 Run scripts/install-deps.sh (it installs the Debian package liblensfun-data-v1).",
                dir.display()
            )
        })
    })
}

fn import(model: &str) -> Imported {
    database().import(model, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn tables(lens: &LensFile) -> &LensTables {
    lens.tables.as_ref().unwrap_or_else(|| panic!("{}: no tables", lens.name))
}

/// The value of `values` at the sample `height_mm` (to the 4 decimals written).
fn at_sample(t: &LensTables, values: &[f64], height_mm: f64) -> f64 {
    let i = t
        .image_height_mm
        .iter()
        .position(|h| (h - height_mm).abs() < 1e-4)
        .unwrap_or_else(|| panic!("{height_mm} mm is not a sample of {:?}", t.image_height_mm));
    values[i]
}

const PRESETS: [(&str, &str); 3] = [
    ("lenses/zeiss-planar-50-f1.4.toml", "Carl Zeiss Planar T* 1,4/50 ZF.2"),
    ("lenses/zeiss-otus-85-f1.4.toml", "Zeiss Otus 85mm f/1.4"),
    ("lenses/zeiss-distagon-21-f2.8.toml", "Carl Zeiss Distagon T* 2,8/21 ZF.2"),
];

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

#[test]
fn distagon_21_distortion_is_lensfuns_ptlens() {
    let imported = import("Carl Zeiss Distagon T* 2,8/21 ZF.2");
    let t = tables(&imported.lens);
    let d = t.distortion_percent.as_ref().expect("distortion table");
    // slr-zeiss.xml: <distortion model="ptlens" focal="21" a="0.03083" b="-0.0633" c="0.01093"/>,
    // calibrated on crop factor 1: r = 1 is half the short side of 36 x 24 mm, 12 mm. Near the
    // axis r_d = d0 r_u with d0 = 1 - a - b - c: the paraxial height is h = d0 r_u 12 mm, and
    // Kyaw's eq 6.8 relative to it is D = 100 (a r^3 + b r^2 + c r) / d0 (0 on the axis).
    let (a, b, c) = (0.03083, -0.0633, 0.01093);
    let d0: f64 = 1.0 - a - b - c;
    assert_eq!(imported.lens.focal_length_mm, 21.0);
    assert_eq!(at_sample(t, d, 0.0), 0.0);
    // The full-frame corner, hypot(36, 24) / 2 = 21.633 mm: r = 21.633 / (12 d0).
    let corner_mm = 36f64.hypot(24.0) / 2.0;
    let r = corner_mm / (12.0 * d0);
    let expect = 100.0 * (a * r * r * r + b * r * r + c * r) / d0;
    // The Distagon's moustache: pincushion near the centre (c > 0), barrel at the corner.
    assert!((expect - -0.8224).abs() < 1e-3, "{expect}");
    let got = at_sample(t, d, corner_mm);
    assert!((got - expect).abs() < 1e-5, "{got} vs {expect}");
    let mid_mm = t.image_height_mm[1];
    assert!(at_sample(t, d, mid_mm) > 0.0, "pincushion at {mid_mm} mm");
    assert_eq!(*t.image_height_mm.last().unwrap(), 21.6333);
    // TCA linear kr = kb = 1.0001: the red image 0.01 % larger than the green one wherever it
    // lands, i.e. 100 (kr - 1) (1 + D/100) over the ideal height.
    let red = t.lateral_color_red_percent.as_ref().expect("red table");
    assert!((at_sample(t, red, corner_mm) - 0.01 * (1.0 + expect / 100.0)).abs() < 1e-5);
    // Crop 1 covers full frame: nothing extrapolated.
    assert!(imported.warnings.is_empty(), "{:?}", imported.warnings);
}

#[test]
fn distagon_35_vignetting_from_the_database() {
    // <vignetting model="pa" focal="35" aperture="2" distance="1000" k1="-1.9515" k2="2.1666" k3="-0.9851"/>
    let imported = import("Carl Zeiss Distagon T* 2/35 ZF.2");
    let t = tables(&imported.lens);
    let f_numbers: Vec<f64> = t.vignetting.iter().map(|v| v.f_number).collect();
    assert_eq!(f_numbers, [2.0, 2.8, 4.0, 5.6, 22.0]);
    // r = 1 at half the diagonal: 1 + k1 + k2 + k3 at the full-frame corner.
    let corner = *t.vignetting[0].relative_illumination.last().unwrap();
    assert!((corner - (1.0 - 1.9515 + 2.1666 - 0.9851)).abs() < 1e-5, "{corner}");
    // Stopping down brightens the corner.
    let corners: Vec<f64> = t.vignetting.iter().map(|v| *v.relative_illumination.last().unwrap()).collect();
    assert!(corners[0] < corners[1] && corners[1] < corners[2], "{corners:?}");
}

#[test]
fn presets_agree_with_a_fresh_import() {
    for (file, model) in PRESETS {
        let preset = LensFile::load(&repo(file)).unwrap_or_else(|e| panic!("{e}"));
        let fresh = import(model).lens;
        assert_eq!(preset.name, model, "{file}");
        assert_eq!(preset.focal_length_mm, fresh.focal_length_mm, "{file}");
        assert_eq!(preset.f_number_min, fresh.f_number_min, "{file}");
        let (p, f) = (tables(&preset), tables(&fresh));
        assert_eq!(p.image_height_mm, f.image_height_mm, "{file}");
        let close = |a: &Option<Vec<f64>>, b: &Option<Vec<f64>>, what: &str| match (a, b) {
            (Some(a), Some(b)) => {
                assert_eq!(a.len(), b.len(), "{file} {what}");
                for (x, y) in a.iter().zip(b) {
                    assert!((x - y).abs() <= 1e-5, "{file} {what}: {x} vs {y}");
                }
            }
            (None, None) => {}
            _ => panic!("{file} {what}: in one of preset and import only"),
        };
        close(&p.distortion_percent, &f.distortion_percent, "distortion_percent");
        close(&p.lateral_color_red_percent, &f.lateral_color_red_percent, "lateral_color_red_percent");
        close(&p.lateral_color_blue_percent, &f.lateral_color_blue_percent, "lateral_color_blue_percent");
        assert_eq!(p.vignetting.len(), f.vignetting.len(), "{file}");
        // The hand-edited settings.
        assert_eq!(preset.aperture.blades, 9, "{file}");
        assert!(preset.spherical_aberration > 0.0, "{file}");
    }
    // The Planar's calibration is APS-C: the full-frame tables are extrapolated, and say so.
    let planar = import("Carl Zeiss Planar T* 1,4/50 ZF.2");
    assert_eq!(planar.entry.crop_factor, Some(1.523));
    assert!(planar.warnings.iter().any(|w| w.contains("extrapolate")), "{:?}", planar.warnings);
    let text = std::fs::read_to_string(repo(PRESETS[0].0)).unwrap();
    assert!(text.contains("EXTRAPOLATED") && text.contains("14.2 mm"), "{text}");
}

#[test]
fn every_lens_file_in_lenses_parses() {
    let mut count = 0;
    for entry in std::fs::read_dir(repo("lenses")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        // A lens file has a focal length; a bare prescription (tessar-walch.toml) has surfaces.
        let is_lens_file = text.parse::<toml::Table>().is_ok_and(|t| t.contains_key("focal_length_mm"));
        if is_lens_file {
            LensFile::parse(&text, &path).unwrap_or_else(|e| panic!("{e}"));
        } else {
            realcam::optics::prescription::Prescription::parse_toml(&text, &path.display().to_string())
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
        count += 1;
    }
    assert!(count >= 5, "only {count} files in lenses/");
}

/// Runs the realcam binary; (exit code, stdout, stderr).
fn realcam(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_realcam")).args(args).output().expect("running realcam");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn cli_import_prints_a_lens_file_or_writes_one() {
    database(); // a clear message when the database is missing
    let model = "Carl Zeiss Distagon T* 2,8/21 ZF.2";
    let (code, stdout, stderr) = realcam(&["lens", "import-lensfun", model]);
    assert_eq!(code, Some(0), "{stderr}");
    let lens = LensFile::parse(&stdout, Path::new("<stdout>")).unwrap_or_else(|e| panic!("{e}\n{stdout}"));
    assert_eq!(lens.name, model);
    assert_eq!(stdout, import(model).toml);
    assert!(stderr.contains("slr-zeiss.xml, line"), "{stderr}");

    let dir = std::env::temp_dir().join(format!("realcam-lensfun-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("otus.toml");
    let (code, stdout, stderr) =
        realcam(&["lens", "import-lensfun", "zeiss otus 85mm F/1.4", "--blades", "9", "--out", out.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.is_empty(), "{stdout}");
    let written = LensFile::load(&out).unwrap_or_else(|e| panic!("{e}"));
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!((written.name.as_str(), written.aperture.blades), ("Zeiss Otus 85mm f/1.4", 9));
}

#[test]
fn cli_unknown_model_fails_with_close_names() {
    database();
    let (code, stdout, stderr) = realcam(&["lens", "import-lensfun", "Planar T* 1.4/50"]);
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(stdout.is_empty());
    assert!(stderr.contains("no lens \"Planar T* 1.4/50\""), "{stderr}");
    assert!(
        stderr.contains("close model names:") && stderr.contains("\"Carl Zeiss Planar T* 1,4/50 ZF.2\""),
        "{stderr}"
    );
    // A fisheye is refused with the reason.
    let (code, _, stderr) = realcam(&["lens", "import-lensfun", "Fisheye 8-20mm f/1.0"]);
    assert_eq!(code, Some(1));
    assert!(stderr.contains("rectilinear lenses only"), "{stderr}");
}

#[test]
fn cli_lens_lensfun_stands_for_a_lens_file() {
    database();
    let (code, stdout, stderr) =
        realcam(&["dof", "--lens-lensfun", "Zeiss Otus 85mm f/1.4", "--fstop", "2", "--coc", "1/1000"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.starts_with("lens: Zeiss Otus 85mm f/1.4\n"), "{stdout}");
    assert!(stdout.contains("85.00 mm"), "{stdout}");
    let (code, _, stderr) = realcam(&["dof", "--lens", "x.toml", "--lens-lensfun", "Zeiss Otus 85mm f/1.4"]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("cannot be used with"), "{stderr}");
    let (code, _, stderr) = realcam(&["dof", "--lens-lensfun", "No Such Lens 50mm", "--coc", "1/1000"]);
    assert_eq!(code, Some(1));
    assert!(stderr.contains("--lens-lensfun \"No Such Lens 50mm\"") && stderr.contains("no lens"), "{stderr}");
}
