//! The registry of file formats arbor reads: every reader is chosen here,
//! by the file's extension (in any case), before any byte is parsed.

use std::path::Path;

use super::LoadError;

/// A file format arbor reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// A Cornell XML scene (2010 or 2015 conventions).
    Xml,
    /// Wavefront OBJ: a mesh under an exact numbering rule, or a model with
    /// MTL materials.
    Obj,
    /// Stanford PLY (ASCII or binary).
    Ply,
    /// STL (ASCII or binary).
    Stl,
    /// glTF 2.0 as JSON with separate or embedded buffers.
    Gltf,
    /// glTF 2.0 binary.
    Glb,
    /// The Cornell `.msh` mesh format.
    Msh,
}

impl Format {
    /// Every format, in the order the messages list them.
    pub const ALL: [Format; 7] = [
        Format::Xml,
        Format::Obj,
        Format::Ply,
        Format::Stl,
        Format::Gltf,
        Format::Glb,
        Format::Msh,
    ];

    /// The lower-case extension naming the format.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Xml => "xml",
            Format::Obj => "obj",
            Format::Ply => "ply",
            Format::Stl => "stl",
            Format::Gltf => "gltf",
            Format::Glb => "glb",
            Format::Msh => "msh",
        }
    }

    /// The error for a file of this format at `path` where another kind
    /// was wanted: `a .EXT file IS; expected EXPECTED`, the one wording of
    /// every reader's refusal.
    pub(crate) fn refused(self, path: &Path, is: &str, expected: &str) -> LoadError {
        LoadError::file(
            path,
            format!("a .{} file {is}; expected {expected}", self.extension()),
        )
    }

    /// The format `path`'s extension names (any case), or an error naming the
    /// file, its extension and every extension arbor reads.
    pub fn from_path(path: &Path) -> Result<Format, LoadError> {
        let ext = path.extension().map(|e| e.to_string_lossy());
        let found = ext.as_deref().and_then(|e| {
            Format::ALL
                .into_iter()
                .find(|f| f.extension().eq_ignore_ascii_case(e))
        });
        found.ok_or_else(|| {
            let named = match &ext {
                Some(e) => format!(".{e}"),
                None => "no extension".to_string(),
            };
            let all: Vec<String> = Format::ALL
                .iter()
                .map(|f| format!(".{}", f.extension()))
                .collect();
            LoadError::file(
                path,
                format!(
                    "not a format arbor reads ({named}); it reads {}",
                    all.join(", ")
                ),
            )
        })
    }

    /// Whether the format is a model that `arbor render` frames by itself
    /// (OBJ, PLY, STL, glTF).
    pub fn is_model(self) -> bool {
        matches!(
            self,
            Format::Obj | Format::Ply | Format::Stl | Format::Gltf | Format::Glb
        )
    }

    /// Whether the format holds one triangle mesh (`.msh`, OBJ, PLY, STL), as
    /// a scene's `Mesh` surface reads it.
    pub fn is_mesh(self) -> bool {
        matches!(self, Format::Msh | Format::Obj | Format::Ply | Format::Stl)
    }

    /// Whether `arbor trace` and `arbor bench` read the format as one mesh
    /// to cast rays at: every mesh format, and glTF with its node
    /// transforms applied.
    pub fn is_ray_mesh(self) -> bool {
        self.is_mesh() || matches!(self, Format::Gltf | Format::Glb)
    }

    /// The extensions of the formats `pick` selects, in [`Format::ALL`]'s
    /// order, as the messages list them (".ply, .stl or .msh"), so that no
    /// message keeps a list of its own.
    pub fn listed(pick: fn(Format) -> bool) -> String {
        let names: Vec<String> = Format::ALL
            .into_iter()
            .filter(|&f| pick(f))
            .map(|f| format!(".{}", f.extension()))
            .collect();
        match names.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            Some((last, _)) => last.clone(),
            None => String::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_extension_in_any_case() {
        for f in Format::ALL {
            let upper = format!("model.{}", f.extension().to_ascii_uppercase());
            assert_eq!(Format::from_path(Path::new(&upper)), Ok(f));
        }
    }

    #[test]
    fn unknown_extensions_are_named_with_the_list() {
        let e = Format::from_path(Path::new("dir/car.3ds")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "dir/car.3ds: not a format arbor reads (.3ds); it reads .xml, .obj, .ply, .stl, .gltf, .glb, .msh"
        );
        let e = Format::from_path(Path::new("formatDetection")).unwrap_err();
        assert!(e.message.contains("(no extension)"), "{e}");
    }

    #[test]
    fn lists_follow_the_registry() {
        assert_eq!(Format::listed(Format::is_mesh), ".obj, .ply, .stl or .msh");
        assert_eq!(
            Format::listed(Format::is_ray_mesh),
            ".obj, .ply, .stl, .gltf, .glb or .msh"
        );
        assert_eq!(Format::listed(|f| f == Format::Xml), ".xml");
        assert_eq!(Format::listed(|_| false), "");
    }
}
