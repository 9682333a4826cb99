//! `arbor render`'s scene overrides: `--spp`, `--size`, `--quick` and
//! `--define NAME=VALUE`. Each one changes the loaded scene exactly as the
//! matching edit of the scene file would (the tests compare the images
//! byte for byte), so a scene needs no copy to be rendered differently.

use arbor::camera::CameraKind;
use arbor::limits::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, MAX_SAMPLES};
use arbor::scene::{Scene, Variant};
use clap::Args;
use glam::DVec3;

use crate::InputError;

/// The scene values `--define` can set, named as the scene file's elements.
pub const DEFINE_NAMES: &str =
    "samples, viewPoint, viewDir, viewUp, projDistance, viewWidth, viewHeight, exposure, backColor";

/// The override flags of `arbor render`.
#[derive(Args, Debug, Default)]
pub struct Overrides {
    /// Samples per pixel, as the scene's `<samples>`: rounded to a square
    /// grid (`--spp 16` is 4x4 per pixel).
    #[arg(long, value_name = "N", value_parser = parse_spp)]
    pub spp: Option<u32>,
    /// Image size in pixels (e.g. `1920x1080`): the camera keeps its
    /// horizontal field of view; the vertical one is fitted to the new shape.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// For framing: a quarter of the width and height, one sample per pixel.
    #[arg(long, conflicts_with_all = ["spp", "size"])]
    pub quick: bool,
    /// Set a scene value, as the scene element of that name would:
    /// samples, viewPoint, viewDir, viewUp, projDistance, viewWidth,
    /// viewHeight (camera), exposure and backColor (2015 scenes). Vectors as
    /// `x,y,z`. Repeatable; applied after --spp, --size and --quick.
    #[arg(long, short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub define: Vec<(String, String)>,
}

impl Overrides {
    /// Changes `scene` as `--quick` and `--define` ask; `--spp` and `--size`
    /// are the library's (`arbor::render::RenderOptions`), applied first.
    pub fn apply_quick_and_defines(&self, scene: &mut Scene) -> Result<(), InputError> {
        if self.quick {
            resize(scene, (scene.width / 4).max(1), (scene.height / 4).max(1));
            scene.samples_per_side = 1;
        }
        for (name, value) in &self.define {
            define(scene, name, value)?;
        }
        Ok(())
    }
}

/// The image becomes `w` x `h` pixels, the horizontal extent of the view
/// kept and the vertical one fitted (square pixels).
pub(crate) fn resize(scene: &mut Scene, w: u32, h: u32) {
    scene.resize(w, h);
}

/// Sets one `--define` value, with the checks the scene reader makes.
fn define(scene: &mut Scene, name: &str, value: &str) -> Result<(), InputError> {
    let bad = |expected: &str| InputError(format!("--define {name}={value}: expected {expected}"));
    let number = || value.trim().parse::<f64>().ok().filter(|x| x.is_finite());
    let positive = || {
        number()
            .filter(|&x| x > 0.0)
            .ok_or_else(|| bad("a number above 0"))
    };
    let vector = || parse_vector(value).ok_or_else(|| bad("three numbers x,y,z"));
    let nonzero = || vector()?.ok_or_else(|| bad("a vector other than 0,0,0"));
    let only_2015 = || {
        (scene.variant == Variant::Cornell2015)
            .then_some(())
            .ok_or_else(|| {
                InputError(format!(
                    "--define {name}: only 2015 scenes (typed <camera>) have a {name}"
                ))
            })
    };
    let camera = &mut scene.camera;
    match name {
        "samples" => {
            let n: u32 = value
                .trim()
                .parse()
                .ok()
                .filter(|&n| i64::from(n) <= MAX_SAMPLES)
                .ok_or_else(|| bad(&format!("a whole number from 0 to {MAX_SAMPLES}")))?;
            scene.samples_per_side = Scene::samples_per_side_for(n);
        }
        "viewPoint" => camera.view_point = vector()?.unwrap_or(DVec3::ZERO),
        "viewDir" => camera.view_dir = nonzero()?,
        "viewUp" => camera.view_up = nonzero()?,
        "projDistance" if camera.kind == CameraKind::Parallel2015 => {
            return Err(InputError(format!(
                "--define {name}: a parallel camera has no projection distance"
            )))
        }
        "projDistance" => camera.proj_distance = positive()?,
        "viewWidth" => camera.view_width = positive()?,
        "viewHeight" => camera.view_height = positive()?,
        "exposure" => {
            only_2015()?;
            let e = number().ok_or_else(|| bad("a number"))?;
            // As in a scene file (spec §2.6): a value <= 0 is ignored.
            if e > 0.0 {
                scene.exposure = e;
            }
        }
        "backColor" => {
            only_2015()?;
            scene.background = vector()?.unwrap_or(DVec3::ZERO);
        }
        _ => {
            return Err(InputError(format!(
                "--define {name}: unknown name; expected one of {DEFINE_NAMES}"
            )))
        }
    }
    if scene.camera.view_up.cross(scene.camera.view_dir) == DVec3::ZERO {
        return Err(InputError(format!(
            "--define {name}={value}: viewUp is parallel to viewDir"
        )));
    }
    Ok(())
}

/// `x,y,z` (commas or spaces): `Some(None)` for the zero vector, so callers
/// that refuse it can say so.
fn parse_vector(text: &str) -> Option<Option<DVec3>> {
    let v: Vec<f64> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<_>>()?;
    let [x, y, z] = v[..] else { return None };
    let v = DVec3::new(x, y, z);
    Some((v != DVec3::ZERO).then_some(v))
}

/// Parses `--spp N` (for clap), within the library's limit.
pub fn parse_spp(text: &str) -> Result<u32, String> {
    text.trim()
        .parse::<u32>()
        .ok()
        .filter(|&n| arbor::render::valid_samples(n.into()))
        .ok_or_else(|| format!("`{text}`: expected a whole number from 1 to {MAX_SAMPLES}"))
}

/// Parses `--size WxH` (for clap), within the scene reader's limits.
pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let err = || {
        format!(
            "`{text}`: expected WIDTHxHEIGHT, e.g. 640x480, sides from 1 to {MAX_IMAGE_SIDE} and at most {MAX_IMAGE_PIXELS} pixels"
        )
    };
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(err)?;
    let side = |s: &str| {
        s.trim()
            .parse::<i64>()
            .ok()
            .filter(|&n| arbor::render::valid_side(n))
    };
    let (w, h) = (side(w).ok_or_else(err)?, side(h).ok_or_else(err)?);
    if !arbor::render::valid_pixels(w, h) {
        return Err(err());
    }
    Ok((w as u32, h as u32))
}

/// Parses `--define NAME=VALUE` (for clap); the name is checked on use.
pub fn parse_define(text: &str) -> Result<(String, String), String> {
    match text.split_once('=') {
        Some((name, value)) if !name.trim().is_empty() => {
            Ok((name.trim().to_string(), value.to_string()))
        }
        _ => Err(format!("`{text}`: expected NAME=VALUE, e.g. samples=16")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        arbor::default_scene::classroom()
    }

    #[test]
    fn parses() {
        assert_eq!(parse_size("640x480"), Ok((640, 480)));
        assert_eq!(parse_size("7X5"), Ok((7, 5)));
        assert!(parse_size("0x5").is_err());
        assert!(parse_size("640").is_err());
        assert!(parse_size("65536x65536").is_err());
        assert_eq!(parse_spp("16"), Ok(16));
        assert!(parse_spp("0").is_err());
        assert!(parse_spp("many").is_err());
        assert_eq!(
            parse_define("viewPoint=1,2,3"),
            Ok(("viewPoint".into(), "1,2,3".into()))
        );
        assert!(parse_define("=3").is_err());
        assert!(parse_define("samples").is_err());
        assert_eq!(
            parse_vector("1, 2 3"),
            Some(Some(DVec3::new(1.0, 2.0, 3.0)))
        );
        assert_eq!(parse_vector("0,0,0"), Some(None));
        assert_eq!(parse_vector("1,2"), None);
        assert_eq!(parse_vector("1,2,nan"), None);
    }

    #[test]
    fn size_keeps_the_horizontal_view() {
        let mut s = scene();
        let width = s.camera.view_width;
        resize(&mut s, 40, 10);
        assert_eq!((s.width, s.height), (40, 10));
        assert_eq!(s.camera.view_width, width);
        assert_eq!(s.camera.view_height, width / 4.0);
    }

    #[test]
    fn quick_is_a_quarter_and_one_sample() {
        let mut s = scene();
        let (w, h) = (s.width, s.height);
        s.samples_per_side = 3;
        let o = Overrides {
            quick: true,
            ..Default::default()
        };
        o.apply_quick_and_defines(&mut s).unwrap();
        assert_eq!((s.width, s.height, s.samples_per_side), (w / 4, h / 4, 1));
    }

    #[test]
    fn defines_check_their_values() {
        let mut s = scene();
        let d = |s: &mut Scene, n: &str, v: &str| define(s, n, v).map_err(|e| e.0);
        d(&mut s, "viewPoint", "1,2,3").unwrap();
        assert_eq!(s.camera.view_point, DVec3::new(1.0, 2.0, 3.0));
        d(&mut s, "samples", "9").unwrap();
        assert_eq!(s.samples_per_side, 3);
        assert!(d(&mut s, "viewDir", "0,0,0")
            .unwrap_err()
            .contains("other than 0,0,0"));
        assert!(d(&mut s, "viewWidth", "-1")
            .unwrap_err()
            .contains("above 0"));
        assert!(d(&mut s, "colour", "1")
            .unwrap_err()
            .contains("unknown name"));
        let up = s.camera.view_up;
        assert!(d(&mut s, "viewDir", &format!("{},{},{}", up.x, up.y, up.z))
            .unwrap_err()
            .contains("parallel"));
    }
}
