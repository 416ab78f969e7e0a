//! Geoid heights from EGM96, for data whose heights are above mean sea level.
//!
//! 3D Tiles places content by height above the WGS84 ellipsoid, while building data measures heights from a
//! geoid or a local datum close to one (NAP, NAVD88, …). The difference, the geoid height N, is tens of metres
//! (+43 m at Delft, −29 m at Boston). `geoid_height_m` gives EGM96's N anywhere on Earth from the 15′ grid NGA
//! publishes (`data/egm96-15min.bin`, see `data/README.md`), interpolated bilinearly, which stays within a few
//! centimetres of the spherical-harmonic model.

/// The grid: 721 rows from 90° N to 90° S and 1,440 columns from 0° eastwards, every 15′; big-endian 16-bit
/// integers in centimetres.
const GRID: &[u8] = include_bytes!("../data/egm96-15min.bin");
const ROWS: usize = 721;
const COLS: usize = 1440;
/// Grid spacing in degrees.
const STEP_DEG: f64 = 0.25;

fn node_m(row: usize, col: usize) -> f64 {
    let i = 2 * (row * COLS + col);
    f64::from(i16::from_be_bytes([GRID[i], GRID[i + 1]])) / 100.0
}

/// EGM96 geoid height (metres above the WGS84 ellipsoid) at a latitude and longitude in degrees. Latitudes are
/// clamped to ±90°, longitudes taken modulo 360°; `None` for a coordinate that is not a finite number.
pub fn geoid_height_m(lat_deg: f64, lon_deg: f64) -> Option<f64> {
    if !(lat_deg.is_finite() && lon_deg.is_finite()) {
        return None;
    }
    let y = (90.0 - lat_deg.clamp(-90.0, 90.0)) / STEP_DEG;
    let x = lon_deg.rem_euclid(360.0) / STEP_DEG;
    // The last row and the column past 360° interpolate towards the row above and column 0.
    let row = (y.floor() as usize).min(ROWS - 2);
    let col = (x.floor() as usize).min(COLS - 1);
    let (fy, fx) = (y - row as f64, x - col as f64);
    let east = (col + 1) % COLS;
    let north = node_m(row, col) * (1.0 - fx) + node_m(row, east) * fx;
    let south = node_m(row + 1, col) * (1.0 - fx) + node_m(row + 1, east) * fx;
    Some(north * (1.0 - fy) + south * fy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_has_the_published_size() {
        assert_eq!(GRID.len(), ROWS * COLS * 2);
    }

    /// NGA's check points for EGM96 (the values its interpolation program is distributed with, computed from the
    /// spherical harmonics): bilinear interpolation on the 15′ grid stays within 6 cm of every one.
    #[test]
    fn matches_the_published_check_points() {
        let points = [
            (38.628155, 269.779155, -31.628),
            (-14.621217, 305.021114, -2.969),
            (46.874319, 102.448729, -43.575),
            (-23.617446, 133.874712, 15.871),
            (38.625473, 359.9995, 50.066),
            (-0.466744, 0.0023, 17.329),
        ];
        for (lat, lon, n) in points {
            let got = geoid_height_m(lat, lon).unwrap();
            assert!(
                (got - n).abs() < 0.06,
                "({lat}, {lon}): {got:.3} m, published {n} m"
            );
        }
    }

    #[test]
    fn poles_antimeridian_and_negative_longitudes_are_read() {
        // The poles are one value along their row.
        assert_eq!(geoid_height_m(90.0, 0.0), Some(13.61));
        assert_eq!(geoid_height_m(90.0, 123.4), Some(13.61));
        assert_eq!(geoid_height_m(-90.0, -45.0), Some(-29.53));
        // West longitudes are the same place as 360° less them, and 180° the same as −180°.
        let (a, b) = (
            geoid_height_m(40.7, -74.0).unwrap(),
            geoid_height_m(40.7, 286.0).unwrap(),
        );
        assert!((a - b).abs() < 1e-9, "{a} {b}");
        let (a, b) = (
            geoid_height_m(-17.0, 180.0).unwrap(),
            geoid_height_m(-17.0, -180.0).unwrap(),
        );
        assert!((a - b).abs() < 1e-9, "{a} {b}");
        // Continuous across the last column back to column 0.
        let (a, b) = (
            geoid_height_m(10.0, 359.999_999).unwrap(),
            geoid_height_m(10.0, 0.0).unwrap(),
        );
        assert!((a - b).abs() < 1e-3, "{a} {b}");
        assert_eq!(geoid_height_m(f64::NAN, 0.0), None);
        assert_eq!(geoid_height_m(0.0, f64::INFINITY), None);
    }

    #[test]
    fn the_three_cities_have_their_known_geoid_heights() {
        // Delft ~+43.5 m (NAP lies ~43 m above the ellipsoid there), Boston ~−28.5 m, New York ~−32.7 m.
        for (lat, lon, lo, hi) in [
            (52.01, 4.36, 43.0, 44.0),
            (42.36, -71.06, -29.0, -28.0),
            (40.715, -73.985, -33.2, -32.2),
        ] {
            let n = geoid_height_m(lat, lon).unwrap();
            assert!((lo..=hi).contains(&n), "({lat}, {lon}): {n}");
        }
    }
}
