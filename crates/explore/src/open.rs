//! Which reader a folder needs: the manifest it holds names the command that wrote it.

use super::error::ExploreError;
use super::folder::RunFolder;
use super::{calibrate_folder, map_folder, search_folder};
use pendulum_atlas_map::output::earlier::EARLIER_DIR;
use pendulum_atlas_map::output::folder::Product;
use std::path::Path;

impl RunFolder {
    /// Read `dir`, refusing a folder that is not a complete map, calibration or search.
    pub fn open(dir: &Path) -> Result<RunFolder, ExploreError> {
        if !dir.is_dir() {
            return Err(ExploreError::MissingFile {
                path: dir.display().to_string(),
                hint: "give the --out folder of a finished `pendulum-atlas map`, `calibrate` \
                       or `search`"
                    .into(),
            });
        }
        match Product::ALL
            .into_iter()
            .find(|p| dir.join(p.manifest()).is_file())
        {
            Some(Product::Map) => map_folder::open(dir),
            Some(Product::Calibrate) => calibrate_folder::open(dir),
            Some(Product::Search) => search_folder::open(dir),
            Some(p) => Err(ExploreError::MissingFile {
                path: dir.join("map.json").display().to_string(),
                hint: format!(
                    "this is the folder of `pendulum-atlas {}` ({} is there); explore reads \
                     the folder of a finished `map` (or `merge`), `calibrate` or `search`",
                    p.command(),
                    p.manifest()
                ),
            }),
            None if dir.join(EARLIER_DIR).is_dir() => Err(ExploreError::MissingFile {
                path: dir.join("map.json").display().to_string(),
                hint: format!(
                    "a `--force` run into this folder was stopped before it completed, and the \
                     earlier complete run it replaced is set aside in `{}`: the next run into \
                     this folder puts it back first (or move its files back into the folder \
                     by hand)",
                    dir.join(EARLIER_DIR).display()
                ),
            }),
            None => Err(ExploreError::MissingFile {
                path: dir.join("map.json").display().to_string(),
                hint: "not a finished map folder (nor calibrate.json or search.json): each \
                       command writes its manifest last, so a run that was stopped has none"
                    .into(),
            }),
        }
    }
}
