//! Accuracy maps side by side as CSV, one row per grid point, in memory:
//! the caller writes the file (parcal's atomic writer does).

use std::path::Path;

use crate::{AccuracyError, AccuracyMap};

/// The content of the CSV file `path` of `maps` (name, map), one row per
/// grid point in map order: `x_mm, y_mm` (design frame), then for each map
/// `{name}_absolute_mm, {name}_registered_mm`. Numbers are written in full
/// precision (mm). Errors name the file: no map, maps on different grids.
pub fn to_csv(path: &Path, maps: &[(&str, &AccuracyMap)]) -> Result<Vec<u8>, AccuracyError> {
    let Some((_, first)) = maps.first() else {
        return Err(AccuracyError::NoMaps {
            path: path.to_path_buf(),
        });
    };
    let grid = &first.grid;
    for (name, map) in maps {
        let fits = map.grid == *grid
            && map.absolute.len() == grid.len()
            && map.registered.len() == grid.len();
        if !fits {
            return Err(AccuracyError::MismatchedGrids {
                path: path.to_path_buf(),
                name: name.to_string(),
            });
        }
    }
    let write_error = |source| AccuracyError::Write {
        path: path.to_path_buf(),
        source,
    };
    let mut writer = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["x_mm".to_string(), "y_mm".to_string()];
    for (name, _) in maps {
        header.push(format!("{name}_absolute_mm"));
        header.push(format!("{name}_registered_mm"));
    }
    writer.write_record(&header).map_err(write_error)?;
    let mut row = Vec::with_capacity(header.len());
    for (k, point) in grid.points().enumerate() {
        row.clear();
        row.push(point.x.to_string());
        row.push(point.y.to_string());
        for (_, map) in maps {
            row.push(map.absolute[k].to_string());
            row.push(map.registered[k].to_string());
        }
        writer.write_record(&row).map_err(write_error)?;
    }
    writer
        .into_inner()
        .map_err(|e| write_error(csv::Error::from(e.into_error())))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MapGrid;

    fn map(grid: &MapGrid, scale: f64) -> AccuracyMap {
        AccuracyMap {
            grid: grid.clone(),
            absolute: (0..grid.len()).map(|k| scale * k as f64).collect(),
            registered: (0..grid.len()).map(|k| scale * 0.5 * k as f64).collect(),
        }
    }

    #[test]
    fn writes_one_row_per_grid_point() {
        let grid = MapGrid::square(10.0, 10.0, 400.0);
        let (predicted, truth) = (map(&grid, 0.001), map(&grid, 0.1));
        let path = Path::new("map.csv");
        let bytes = to_csv(path, &[("predicted", &predicted), ("true", &truth)]).unwrap();
        let text = String::from_utf8(bytes).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 1 + 9);
        assert_eq!(
            lines[0],
            "x_mm,y_mm,predicted_absolute_mm,predicted_registered_mm,true_absolute_mm,true_registered_mm"
        );
        // Point 5 is (ix, iy) = (2, 1): x = 10, y = 0.
        assert_eq!(lines[6], "10,0,0.005,0.0025,0.5,0.25");
    }

    #[test]
    fn errors_name_the_file() {
        let grid = MapGrid::square(10.0, 10.0, 400.0);
        let path = Path::new("out").join("map.csv");
        let other = map(&MapGrid::square(20.0, 10.0, 400.0), 1.0);
        let error = to_csv(&path, &[("a", &map(&grid, 1.0)), ("b", &other)]).unwrap_err();
        assert_eq!(
            error.to_string(),
            format!(
                "{}: map \"b\" does not fit the grid of the first map",
                path.display()
            )
        );
        assert!(matches!(
            to_csv(&path, &[]),
            Err(AccuracyError::NoMaps { .. })
        ));
    }
}
