//! The files a command writes, checked before its work starts: each can be
//! written (absent or a regular file, through symbolic links, in a
//! directory that takes new files), none is a file the run reads and no
//! two are the same file. The command then writes them as a set
//! ([`atomic::write_set`]).

use std::path::{Path, PathBuf};

use parcal::dataset::atomic;
use parcal::dataset::{
    ARTEFACTS_FILE, MACHINE_FILE, MEASUREMENTS_FILE, POINTS_FILE, POSES_FILE, TRUTH_FILE,
};

/// The files read from the dataset `path`: the snapshot file, or those of
/// the directory that exist.
pub fn dataset_inputs(path: &Path) -> Vec<PathBuf> {
    if path.is_file() {
        return vec![path.to_path_buf()];
    }
    [
        MACHINE_FILE,
        ARTEFACTS_FILE,
        MEASUREMENTS_FILE,
        POSES_FILE,
        POINTS_FILE,
        TRUTH_FILE,
    ]
    .iter()
    .map(|name| path.join(name))
    .filter(|file| file.exists())
    .collect()
}

/// Checks that every one of `outputs` can be written, is none of `inputs`
/// (the same file by device and inode, whatever the path) and none of the
/// other outputs (the same [`atomic::destination`], whether or not it
/// exists yet).
pub fn check(inputs: &[PathBuf], outputs: &[PathBuf]) -> anyhow::Result<()> {
    let destinations = outputs
        .iter()
        .map(|output| atomic::destination(output))
        .collect::<Result<Vec<_>, _>>()?;
    for (k, destination) in destinations.iter().enumerate() {
        if let Some(j) = destinations[..k].iter().position(|d| d == destination) {
            anyhow::bail!(
                "{} and {} are the same file, and this run writes both; give them different names",
                outputs[j].display(),
                outputs[k].display()
            );
        }
    }
    for output in outputs {
        if let Some(input) = inputs.iter().find(|input| same_file(output, input)) {
            anyhow::bail!(
                "{}: this output is {}, which this run reads; write it elsewhere",
                output.display(),
                input.display()
            );
        }
        atomic::check_file(output)?;
    }
    Ok(())
}

/// Whether `a` and `b` are the same existing file (symbolic links
/// followed): the same device and inode, or elsewhere the same canonical
/// path.
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let (Ok(a), Ok(b)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
            return false;
        };
        a.dev() == b.dev() && a.ino() == b.ino()
    }
    #[cfg(not(unix))]
    {
        let (Ok(a), Ok(b)) = (std::fs::canonicalize(a), std::fs::canonicalize(b)) else {
            return false;
        };
        a == b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_input_is_never_an_output_whatever_its_path() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("measurements.csv");
        std::fs::write(&input, "x").unwrap();
        let inputs = [input.clone()];
        let roundabout = dir.path().join(".").join("measurements.csv");
        let error = check(&inputs, &[roundabout]).unwrap_err().to_string();
        assert!(error.contains("which this run reads"), "{error}");
        #[cfg(unix)]
        {
            let link = dir.path().join("link.csv");
            std::os::unix::fs::symlink(&input, &link).unwrap();
            assert!(check(&inputs, &[link]).is_err());
        }
        check(&inputs, &[dir.path().join("calibration.json")]).unwrap();
    }

    #[test]
    fn two_outputs_are_never_one_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("commands.csv");
        let roundabout = dir.path().join(".").join("commands.csv");
        let error = check(&[], &[out.clone(), roundabout])
            .unwrap_err()
            .to_string();
        assert!(error.contains("are the same file"), "{error}");
        check(&[], &[out, dir.path().join("poses.csv")]).unwrap();
    }
}
