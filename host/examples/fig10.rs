//! The paper's Fig. 10(c) experiment (issue #22 item 3): RMS point error against unresolvable
//! area, for fixed-pitch paper-8 sets of several fringe numbers and for sets `fringe3d adapt`
//! designs from a first scan, on three rendered scenes (`examples/scenes/adapt_*.toml`).
//! Writes `docs/adaptive/fig10c.svg` and `docs/adaptive/fig10c.json`, and prints the table of
//! docs/adaptive.md.
//!
//! Run: `cargo run --release -p fringe3d --example fig10 [-- --size WxH] [--work DIR]`
//! (full size by default: about 70 s on 2 cores).

use anyhow::{Context, Result};
use fringe3d::adapt::Goal;
use fringe3d::adapt::experiment::{Config, Point, run_scene};
use fringe3d::render::Overrides;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const SCENES: [(&str, &str); 3] = [
    ("cylinder", "adapt_cylinder"),
    ("freeform", "adapt_freeform"),
    ("flanks", "adapt_flanks"),
];

fn main() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut size = None;
    let mut work = std::env::temp_dir().join("fringe3d-fig10");
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--size" => {
                size = Some(
                    fringe3d::cli::parse::size_wh(&args.next().context("--size WxH")?)
                        .map_err(anyhow::Error::msg)?,
                )
            }
            "--work" => work = PathBuf::from(args.next().context("--work DIR")?),
            _ => anyhow::bail!("usage: fig10 [--size WxH] [--work DIR]"),
        }
    }
    let cfg = Config {
        fixed_ratios: vec![4.0, 5.657, 8.0, 11.31, 16.0],
        adapt_ratios: vec![5.657, 8.0, 11.31],
        goal: Goal::default(),
        noise_model: true,
        crop: ([-250.0, -250.0, 450.0], [250.0, 250.0, 715.0]),
        gross_mm: 1.0,
        overrides: Overrides {
            size,
            ..Overrides::default()
        },
    };
    let mut all: Vec<(&str, Vec<Point>)> = Vec::new();
    for (label, file) in SCENES {
        let scene = root.join(format!("examples/scenes/{file}.toml"));
        let t = std::time::Instant::now();
        let points = run_scene(&scene, &cfg, &work.join(file))?;
        eprintln!("{label}: {:.0} s", t.elapsed().as_secs_f64());
        all.push((label, points));
    }
    let _ = std::fs::remove_dir_all(&work);
    let out = root.join("docs/adaptive");
    std::fs::create_dir_all(&out)?;
    std::fs::write(out.join("fig10c.svg"), svg(&all))?;
    let json = serde_json::json!({
        "size": size.map(|(w, h)| format!("{w}x{h}")).unwrap_or_else(|| "1280x1024".into()),
        "goal": format!("{:?}", cfg.goal),
        "gross_mm": cfg.gross_mm,
        "scenes": all.iter().map(|(s, p)| serde_json::json!({"scene": s, "points": p})).collect::<Vec<_>>(),
    });
    std::fs::write(
        out.join("fig10c.json"),
        serde_json::to_string_pretty(&json)? + "\n",
    )?;
    println!("{}", table(&all));
    Ok(())
}

fn table(all: &[(&str, Vec<Point>)]) -> String {
    let mut s = String::from(
        "| scene | set | level ratio | finest fringes | RMS, µm | unresolvable, % | predicted gain |\n|---|---|---|---|---|---|---|\n",
    );
    for (scene, pts) in all {
        for p in pts {
            if let Some(why) = &p.refused {
                let why = why.split(": ").last().unwrap_or(why);
                let _ = writeln!(
                    s,
                    "| {scene} | {} | {:.2} | {:.0} | refused: {} | | |",
                    p.kind,
                    p.ratio,
                    p.fringes,
                    why.split(':').next().unwrap_or(why)
                );
                continue;
            }
            let _ = writeln!(
                s,
                "| {scene} | {} | {:.2} | {:.0} | {:.1} | {:.2} | {} |",
                p.kind,
                p.ratio,
                p.fringes,
                p.rms_mm * 1e3,
                p.unresolvable * 100.0,
                p.predicted_gain.map_or("".into(), |g| format!("×{g:.2}"))
            );
        }
    }
    s
}

/// One panel per scene: RMS (log scale) against unresolvable area, fixed-pitch sets as a line
/// labelled by fringe number, adapted sets as a second line.
fn svg(all: &[(&str, Vec<Point>)]) -> String {
    let (pw, ph, m) = (320.0, 260.0, 48.0);
    let width = m + all.len() as f64 * (pw + m);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
        ph + 2.0 * m
    );
    for (k, (scene, pts)) in all.iter().enumerate() {
        let x0 = m + k as f64 * (pw + m);
        let y0 = m;
        let good: Vec<&Point> = pts.iter().filter(|p| p.rms_mm.is_finite()).collect();
        let xmax = good
            .iter()
            .map(|p| p.unresolvable * 100.0)
            .fold(1.0f64, f64::max)
            * 1.1;
        let (lo, hi) = good.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.rms_mm * 1e3), b.max(p.rms_mm * 1e3))
        });
        let (lo, hi) = (
            lo.log10().floor(),
            hi.log10().ceil().max(lo.log10().floor() + 1.0),
        );
        let px = |u: f64| x0 + u / xmax * pw;
        let py = |r: f64| y0 + ph - ((r * 1e3).log10() - lo) / (hi - lo) * ph;
        let _ = writeln!(
            s,
            "<rect x=\"{x0}\" y=\"{y0}\" width=\"{pw}\" height=\"{ph}\" fill=\"none\" stroke=\"black\"/>\n<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"13\">{scene}</text>\n<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">unresolvable area, % of the object</text>",
            x0 + pw / 2.0,
            y0 - 10.0,
            x0 + pw / 2.0,
            y0 + ph + 32.0
        );
        for d in lo as i32..=hi as i32 {
            let y = y0 + ph - (f64::from(d) - lo) / (hi - lo) * ph;
            let _ = writeln!(
                s,
                "<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{} µm</text><line x1=\"{x0}\" x2=\"{}\" y1=\"{y}\" y2=\"{y}\" stroke=\"#ddd\"/>",
                x0 - 4.0,
                y + 4.0,
                10f64.powi(d),
                x0 + pw
            );
        }
        for t in 0..=4 {
            let u = xmax * f64::from(t) / 4.0;
            let _ = writeln!(
                s,
                "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{u:.1}</text>",
                px(u),
                y0 + ph + 14.0
            );
        }
        for (kind, colour) in [("fixed", "#1f77b4"), ("adaptive", "#d62728")] {
            let line: Vec<&&Point> = good.iter().filter(|p| p.kind == kind).collect();
            let path: Vec<String> = line
                .iter()
                .map(|p| format!("{:.1},{:.1}", px(p.unresolvable * 100.0), py(p.rms_mm)))
                .collect();
            let _ = writeln!(
                s,
                "<polyline points=\"{}\" fill=\"none\" stroke=\"{colour}\"/>",
                path.join(" ")
            );
            for p in line {
                let (x, y) = (px(p.unresolvable * 100.0), py(p.rms_mm));
                let _ = writeln!(
                    s,
                    "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"3\" fill=\"{colour}\"/><text x=\"{:.1}\" y=\"{:.1}\" fill=\"{colour}\">{:.0}</text>",
                    x + 5.0,
                    y - 4.0,
                    p.fringes
                );
            }
        }
        if k == 0 {
            let _ = writeln!(
                s,
                "<text x=\"{}\" y=\"{}\" fill=\"#1f77b4\">fixed pitch (label: finest fringes)</text><text x=\"{}\" y=\"{}\" fill=\"#d62728\">adapted to the object</text>",
                x0 + 8.0,
                y0 + 16.0,
                x0 + 8.0,
                y0 + 30.0
            );
        }
    }
    s + "</svg>\n"
}
