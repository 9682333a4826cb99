//! `arbor render --tile K/N` and `--region x0,y0,x1,y1`: which pixels a
//! partial render computes, and where its `.part` file goes. The format is
//! `arbor::partial`'s; the cut into tiles is [`arbor::partial::tile_region`]
//! (N horizontal bands of whole rows, as even as possible).

use std::path::{Path, PathBuf};

use arbor::partial::tile_region;
use arbor::render::Region;
use arbor::scene::Scene;

use crate::InputError;

/// The extension of part files.
pub const PART_EXTENSION: &str = "part";

/// What a partial render covers: a tile of a cut, or a free rectangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartSpec {
    /// Tile `k` of `n`.
    Tile(u32, u32),
    /// A rectangle `x0,y0,x1,y1` (ends excluded).
    Region(Region),
}

/// Parses `K/N` (for clap): `0 <= K < N`.
pub fn parse_tile(text: &str) -> Result<(u32, u32), String> {
    let (k, n) = text
        .split_once('/')
        .ok_or_else(|| format!("`{text}`: expected K/N, e.g. 3/8"))?;
    let number = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{text}`: expected K/N with whole numbers, e.g. 3/8"))
    };
    let (k, n) = (number(k)?, number(n)?);
    if n == 0 || k >= n {
        return Err(format!("`{text}`: K must be between 0 and N-1"));
    }
    Ok((k, n))
}

/// Parses `x0,y0,x1,y1` (for clap): a non-empty rectangle, ends excluded.
pub fn parse_region(text: &str) -> Result<Region, String> {
    let v: Vec<u32> = text
        .split(',')
        .map(|s| s.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("`{text}`: expected x0,y0,x1,y1 with whole numbers"))?;
    let [x0, y0, x1, y1] = v[..] else {
        return Err(format!("`{text}`: expected four numbers x0,y0,x1,y1"));
    };
    if x0 >= x1 || y0 >= y1 {
        return Err(format!("`{text}`: need x0 < x1 and y0 < y1"));
    }
    Ok(Region { x0, y0, x1, y1 })
}

/// The spec from the two flags (clap makes them exclusive).
pub fn spec(tile: Option<(u32, u32)>, region: Option<Region>) -> Option<PartSpec> {
    match (tile, region) {
        (Some((k, n)), _) => Some(PartSpec::Tile(k, n)),
        (None, Some(r)) => Some(PartSpec::Region(r)),
        (None, None) => None,
    }
}

/// The region and tile number of `spec` in `scene`'s image, or an input
/// error when it does not fit the image.
pub fn resolve(spec: PartSpec, scene: &Scene) -> Result<(Region, Option<(u32, u32)>), InputError> {
    let (w, h) = (scene.width, scene.height);
    match spec {
        PartSpec::Tile(k, n) => tile_region(w, h, k, n)
            .map(|r| (r, Some((k, n))))
            .ok_or_else(|| {
                InputError(format!(
                    "--tile {k}/{n}: the image has {h} rows; N must be at most {h} so that every tile has a row"
                ))
            }),
        PartSpec::Region(r) => {
            if r.x1 > w || r.y1 > h {
                return Err(InputError(format!(
                    "--region {},{},{},{}: outside the {w}x{h} image",
                    r.x0, r.y0, r.x1, r.y1
                )));
            }
            Ok((r, None))
        }
    }
}

/// The default part file name: `STEM.tile-K-of-N.part` or
/// `STEM.region-x0-y0-x1-y1.part`.
pub fn default_output(stem: &str, spec: PartSpec) -> PathBuf {
    PathBuf::from(match spec {
        PartSpec::Tile(k, n) => format!("{stem}.tile-{k}-of-{n}.{PART_EXTENSION}"),
        PartSpec::Region(r) => format!(
            "{stem}.region-{}-{}-{}-{}.{PART_EXTENSION}",
            r.x0, r.y0, r.x1, r.y1
        ),
    })
}

/// Whether `path` names a part file (`.part`, any case).
pub fn is_part_path(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(PART_EXTENSION))
}

/// The output of `arbor render` from its flags: `-o` if given; else for
/// `--tile`/`--region`, `STEM.tile-K-of-N.part` or
/// `STEM.region-x0-y0-x1-y1.part` in the current directory; else (and for
/// `--crop`) the default picture.
pub fn output_path(
    spec: Option<PartSpec>,
    output: Option<&Path>,
    default_picture: &Path,
    crop: bool,
) -> PathBuf {
    match (output, spec) {
        (Some(o), _) => o.to_path_buf(),
        (None, Some(spec)) if !crop => {
            let stem = default_picture
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "out".into());
            default_output(&stem, spec)
        }
        (None, _) => default_picture.to_path_buf(),
    }
}

/// Whether the render writes a `.part` file (`true`) or a picture. A
/// `.part` output without `--tile` or `--region` is the whole image as
/// one part; `--tile` and `--region` only write parts (`--crop` may write
/// either).
pub fn check_kind(spec: Option<PartSpec>, output: &Path, crop: bool) -> Result<bool, InputError> {
    let is_part = is_part_path(output);
    if spec.is_some() && !is_part && !crop {
        return Err(InputError(format!(
            "{}: --tile and --region write a partial image for `arbor merge`; name it NAME.{PART_EXTENSION} (or use --crop for a picture)",
            output.display()
        )));
    }
    Ok(is_part)
}

/// The whole image of `scene` as a region.
pub fn whole(scene: &Scene) -> Region {
    Region {
        x0: 0,
        y0: 0,
        x1: scene.width,
        y1: scene.height,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses() {
        assert_eq!(parse_tile("3/8"), Ok((3, 8)));
        assert!(parse_tile("8/8").is_err());
        assert!(parse_tile("0/0").is_err());
        assert!(parse_tile("-1/8").is_err());
        assert!(parse_tile("3").is_err());
        assert_eq!(
            parse_region("1,2,3,4"),
            Ok(Region {
                x0: 1,
                y0: 2,
                x1: 3,
                y1: 4
            })
        );
        assert!(parse_region("3,2,1,4").is_err());
        assert!(parse_region("1,2,3").is_err());
        assert!(parse_region("a,2,3,4").is_err());
    }
}
