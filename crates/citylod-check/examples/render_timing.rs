//! Times the renderer on a synthetic city of about one million triangles at 1024×768 and writes the
//! standard views and one cut-versus-full comparison as PNGs.
//! Usage: `cargo run --release -p citylod-check --example render_timing -- [OUT_DIR]`.

use std::time::Instant;

use citylod_check::{box_mesh, compare, standard_views, Renderer, Scene, SKY};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::path::PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "render-out".into()),
    );
    std::fs::create_dir_all(&out)?;

    // 289 × 289 blocks of 12 m buildings on a 20 m grid with deterministic heights: 83,521 boxes,
    // 1,002,252 triangles. The "cut" merges each 2 × 2 group into one box of the mean height.
    let n = 289;
    let (mut full, mut cut) = (Scene::new(), Scene::new());
    let height = |i: u32, j: u32| 6.0 + f64::from((i * 7919 + j * 104_729) % 37);
    let half = f64::from(n) * 10.0;
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (f64::from(i) * 20.0 - half, f64::from(j) * 20.0 - half);
            let colour = [200, 190 - (i % 3) as u8 * 20, 170, 255];
            full.add_mesh(
                &box_mesh([x, y, 0.0], [x + 12.0, y + 12.0, height(i, j)]),
                colour,
                i * n + j,
            )?;
            if i % 2 == 0 && j % 2 == 0 {
                let group: Vec<(u32, u32)> = [(0, 0), (1, 0), (0, 1), (1, 1)]
                    .into_iter()
                    .map(|(a, b)| (i + a, j + b))
                    .filter(|&(a, b)| a < n && b < n)
                    .collect();
                let h = group.iter().map(|&(a, b)| height(a, b)).sum::<f64>() / group.len() as f64;
                let ext = if group.len() == 4 { 32.0 } else { 12.0 };
                cut.add_mesh(
                    &box_mesh([x, y, 0.0], [x + ext, y + ext, h]),
                    [200, 170, 170, 255],
                    i * n + j,
                )?;
            }
        }
    }
    println!(
        "full: {} triangles, cut: {} triangles",
        full.triangle_count(),
        cut.triangle_count()
    );

    let t = Instant::now();
    let renderer = Renderer::new()?;
    println!(
        "adapter: {} (opened in {:.2?})",
        renderer.adapter_name(),
        t.elapsed()
    );
    let (lo, hi) = full.bounds().ok_or("empty scene")?;
    // Looking up at the sky: every triangle is rejected on the CPU, so this times the CPU pass
    // (transform, shading, rejection) plus the fixed cost of a frame.
    let away = citylod_check::Camera::from_enu([0.0, 0.0, 500.0], 0.0, 90.0, 45.0)?;
    let t = Instant::now();
    renderer.render(&full, &away, 1024, 768)?;
    println!(
        "CPU pass + frame overhead (nothing drawn): {:.2?}",
        t.elapsed()
    );
    let views = standard_views(lo, hi, 6);
    for (k, cam) in views.iter().enumerate() {
        let t = Instant::now();
        let img = renderer.render(&full, cam, 1024, 768)?;
        let dt = t.elapsed();
        let t2 = Instant::now();
        let again = renderer.render(&full, cam, 1024, 768)?;
        let dt2 = t2.elapsed();
        assert_eq!(img, again, "render must be deterministic");
        img.save_png(&out.join(format!("view{k}-full.png")))?;
        let c = renderer.render(&cut, cam, 1024, 768)?;
        c.save_png(&out.join(format!("view{k}-cut.png")))?;
        let m = compare(&c, &img, SKY)?;
        m.diff.save_png(&out.join(format!("view{k}-diff.png")))?;
        println!(
            "view {k}: eye z {:.0} m, full render {dt:.2?} / {dt2:.2?}; changed {:.1} %, skyline max {} px mean {:.2} px, largest added {} px",
            cam.eye_m[2],
            100.0 * m.changed_fraction,
            m.skyline_max_shift_px,
            m.skyline_mean_shift_px,
            m.largest_added_region_px
        );
    }
    Ok(())
}
