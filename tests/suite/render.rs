//! Renders every figure type on small synthetic data and checks the PNGs.
//! Set `RENDER_TEST_OUT=/some/dir` to keep the pictures for inspection.

use std::collections::HashSet;
use std::f64::consts::PI;
use std::path::PathBuf;

use pendulum_atlas_map::output::npy::{write_npy_f32, write_npy_f64, write_npy_i32, write_npy_u8};
use pendulum_atlas_map::render::{
    Axis, Category, CellMarks, Palette, Panel, RGBColor, Series, heatmap, histogram, line_chart,
    scalogram, scatter, stacked_panels, zero_one_figure,
};

fn out(name: &str) -> PathBuf {
    let dir = match std::env::var_os("RENDER_TEST_OUT") {
        Some(d) => PathBuf::from(d),
        None => std::env::temp_dir().join(format!("scratch-render-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Decodes the PNG, checks its size and returns the set of distinct colours.
fn colours(path: &PathBuf, w: u32, h: u32) -> HashSet<[u8; 3]> {
    let img = image::open(path).expect("decodable PNG").to_rgb8();
    assert_eq!(img.dimensions(), (w, h), "{}", path.display());
    img.pixels().map(|p| p.0).collect()
}

fn assert_not_blank(path: &PathBuf, w: u32, h: u32, min_colours: usize) -> HashSet<[u8; 3]> {
    let c = colours(path, w, h);
    assert!(
        c.len() >= min_colours,
        "{}: only {} colours",
        path.display(),
        c.len()
    );
    assert!(c.contains(&[255, 255, 255]), "white background expected");
    c
}

fn linspace(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
        .collect()
}

#[test]
fn line_chart_multi_and_log() {
    let t = linspace(0.0, 10.0, 500);
    let mut y1: Vec<f64> = t.iter().map(|t| (2.0 * t).sin()).collect();
    let y2: Vec<f64> = t.iter().map(|t| 0.5 * (3.0 * t).cos()).collect();
    y1[100] = f64::NAN;
    let s = [
        Series {
            name: "sin 2t",
            x: &t,
            y: &y1,
        },
        Series {
            name: "0.5 cos 3t",
            x: &t,
            y: &y2,
        },
    ];
    let p = out("line.png");
    line_chart(
        &p,
        "Two signals",
        "Time (s)",
        "Angle (rad)",
        &s,
        false,
        false,
    )
    .unwrap();
    assert_not_blank(&p, 1000, 700, 20);

    let f = linspace(0.0, 50.0, 400);
    let psd: Vec<f64> = f
        .iter()
        .map(|f| 1.0 / (1.0 + (f - 5.0).powi(2)) + 1e-4)
        .collect();
    let p = out("line_loglog.png");
    let s = [Series {
        name: "PSD",
        x: &f,
        y: &psd,
    }];
    line_chart(
        &p,
        "Spectrum",
        "Frequency (Hz)",
        "PSD (rad²/Hz)",
        &s,
        true,
        true,
    )
    .unwrap();
    assert_not_blank(&p, 1000, 700, 10);
}

#[test]
fn line_chart_degenerate_inputs() {
    let p = out("line_empty.png");
    line_chart(&p, "Empty", "x (s)", "y (m)", &[], false, false).unwrap();
    assert_not_blank(&p, 1000, 700, 2);
    let c = [2.0; 10];
    let x = linspace(0.0, 1.0, 10);
    let nan = [f64::NAN; 10];
    let s = [
        Series {
            name: "constant",
            x: &x,
            y: &c,
        },
        Series {
            name: "nan",
            x: &x,
            y: &nan,
        },
        Series {
            name: "empty",
            x: &[],
            y: &[],
        },
    ];
    line_chart(
        &out("line_const.png"),
        "Const",
        "x (s)",
        "y (m)",
        &s,
        false,
        true,
    )
    .unwrap();
    let bad = [Series {
        name: "bad",
        x: &x,
        y: &c[..3],
    }];
    assert!(line_chart(&out("line_bad.png"), "Bad", "x", "y", &bad, false, false).is_err());
}

#[test]
fn stacked_panels_three() {
    let t = linspace(0.0, 20.0, 2000);
    let th: Vec<f64> = t
        .iter()
        .map(|t| 0.3 * (t * 1.3).sin() * (-0.05 * t).exp())
        .collect();
    let om: Vec<f64> = t.iter().map(|t| 0.39 * (t * 1.3).cos()).collect();
    let f = linspace(0.01, 5.0, 300);
    let s: Vec<f64> = f.iter().map(|f| 1.0 / (1e-3 + (f - 0.2).powi(2))).collect();
    let panels = [
        Panel {
            x_label: "Time (s)",
            y_label: "θ (rad)",
            series: vec![Series {
                name: "θ",
                x: &t,
                y: &th,
            }],
            log_y: false,
        },
        Panel {
            x_label: "Time (s)",
            y_label: "ω (rad/s)",
            series: vec![Series {
                name: "ω",
                x: &t,
                y: &om,
            }],
            log_y: false,
        },
        Panel {
            x_label: "Frequency (Hz)",
            y_label: "PSD (rad²/Hz)",
            series: vec![Series {
                name: "PSD",
                x: &f,
                y: &s,
            }],
            log_y: true,
        },
    ];
    let p = out("stacked.png");
    stacked_panels(&p, "Impacting pendulum, a = 0.1", &panels).unwrap();
    assert_not_blank(&p, 1000, 960, 10);
    assert!(stacked_panels(&out("stacked_none.png"), "None", &[]).is_err());
}

/// (times, periods, power, coi, significance ratio)
type Wavelet = (Vec<f64>, Vec<f64>, Vec<Vec<f64>>, Vec<f64>, Vec<Vec<f64>>);

fn synthetic_wavelet(nt: usize, np: usize) -> Wavelet {
    let times = linspace(0.0, 100.0, nt);
    let periods: Vec<f64> = (0..np).map(|j| 0.5 * 2f64.powf(j as f64 / 4.0)).collect();
    let power: Vec<Vec<f64>> = periods
        .iter()
        .map(|&p| {
            times
                .iter()
                .map(|&t| {
                    let centre = if t < 50.0 { 4.0 } else { 8.0 };
                    8.0 * (-(p / centre).log2().powi(2) * 4.0).exp() + 0.05
                })
                .collect()
        })
        .collect();
    let coi: Vec<f64> = times
        .iter()
        .map(|&t| 1.03 * t.min(100.0 - t) / 2f64.sqrt())
        .collect();
    let sig = power
        .iter()
        .map(|r| r.iter().map(|v| v / 2.0).collect())
        .collect();
    (times, periods, power, coi, sig)
}

#[test]
fn scalogram_renders_and_validates() {
    let (times, periods, power, coi, sig) = synthetic_wavelet(400, 30);
    let p = out("scalogram.png");
    scalogram(
        &p,
        "Wavelet power spectrum",
        &times,
        &periods,
        &power,
        &coi,
        Some(&sig),
        "Time (s)",
    )
    .unwrap();
    let c = assert_not_blank(&p, 1000, 700, 50);
    assert!(c.contains(&[0, 0, 0]));
    // Without COI / significance, and with zero power (log2 = -inf).
    let mut zero = power.clone();
    zero[3][7] = 0.0;
    scalogram(
        &out("scalogram_plain.png"),
        "Plain",
        &times,
        &periods,
        &zero,
        &[],
        None,
        "Time (s)",
    )
    .unwrap();
    // Single period row, shape errors.
    scalogram(
        &out("scalogram_1row.png"),
        "One",
        &times,
        &periods[..1],
        &power[..1],
        &coi,
        None,
        "Time (s)",
    )
    .unwrap();
    assert!(
        scalogram(
            &out("sc_bad.png"),
            "Bad",
            &times,
            &periods,
            &power[..3],
            &coi,
            None,
            "t (s)"
        )
        .is_err()
    );
    assert!(
        scalogram(
            &out("sc_bad2.png"),
            "Bad",
            &times,
            &[],
            &[],
            &coi,
            None,
            "t (s)"
        )
        .is_err()
    );
}

const MAGENTA: [u8; 3] = [255, 0, 255];

#[test]
fn heatmap_invalid_cells_and_shapes() {
    let xs: Vec<f64> = (0..20).map(|i| 0.1 * (i as f64).powf(1.3)).collect();
    let ys = linspace(0.5, 2.0, 15);
    let vals: Vec<f64> = ys
        .iter()
        .flat_map(|&y| xs.iter().map(move |&x| (x * y).sin()))
        .collect();
    let x = Axis {
        label: "Amplitude a (m)",
        values: &xs,
    };
    let y = Axis {
        label: "Frequency f (Hz)",
        values: &ys,
    };
    let mut inv = vec![false; vals.len()];
    inv[37] = true;
    inv[38] = true;
    let p = out("heatmap_invalid.png");
    heatmap(
        &p,
        "Largest Lyapunov exponent",
        &x,
        &y,
        &vals,
        "λ (1/s)",
        &CellMarks {
            invalid: &inv,
            ..CellMarks::default()
        },
        &Palette::Sequential(None),
    )
    .unwrap();
    assert!(assert_not_blank(&p, 1000, 700, 30).contains(&MAGENTA));

    let p = out("heatmap_valid.png");
    heatmap(
        &p,
        "All valid",
        &x,
        &y,
        &vals,
        "λ (1/s)",
        &CellMarks {
            invalid: &vec![false; vals.len()],
            ..CellMarks::default()
        },
        &Palette::Sequential(Some((-1.0, 1.0))),
    )
    .unwrap();
    assert!(!assert_not_blank(&p, 1000, 700, 30).contains(&MAGENTA));

    // A curve drawn over the cells (the orbit stage's bifurcation curves) shows in its colour.
    let p = out("heatmap_curve.png");
    let colour = pendulum_atlas_map::render::RGBColor(3, 200, 7);
    let lines = [pendulum_atlas_map::render::Overlay {
        points: vec![(xs[2], ys[2]), (xs[10], ys[8]), (xs[15], ys[12])],
        colour,
        label: "a curve".into(),
    }];
    let marks = CellMarks {
        lines: &lines,
        ..CellMarks::default()
    };
    let palette = Palette::Sequential(Some((-1.0, 1.0)));
    heatmap(&p, "With a curve", &x, &y, &vals, "v", &marks, &palette).unwrap();
    assert!(assert_not_blank(&p, 1000, 700, 30).contains(&[3, 200, 7]));

    // 1×N, N×1, 1×1, constant / NaN values, empty flag slice.
    let one = [1.0];
    let y1 = Axis {
        label: "f (Hz)",
        values: &one,
    };
    heatmap(
        &out("heatmap_row.png"),
        "Row",
        &x,
        &y1,
        &vals[..20],
        "v",
        &CellMarks::default(),
        &Palette::Sequential(None),
    )
    .unwrap();
    let x1 = Axis {
        label: "a (m)",
        values: &one,
    };
    let p = out("heatmap_col.png");
    heatmap(
        &p,
        "Column",
        &x1,
        &y,
        &vals[..15],
        "v",
        &CellMarks::default(),
        &Palette::Sequential(None),
    )
    .unwrap();
    assert!(!colours(&p, 1000, 700).contains(&MAGENTA));
    heatmap(
        &out("heatmap_1x1.png"),
        "One",
        &x1,
        &y1,
        &[f64::NAN],
        "v",
        &CellMarks::default(),
        &Palette::Sequential(None),
    )
    .unwrap();
    heatmap(
        &out("heatmap_const.png"),
        "Const",
        &x1,
        &y,
        &[3.0; 15],
        "v",
        &CellMarks::default(),
        &Palette::Sequential(None),
    )
    .unwrap();

    assert!(
        heatmap(
            &out("hm_bad.png"),
            "Bad",
            &x,
            &y,
            &vals[..5],
            "v",
            &CellMarks::default(),
            &Palette::Sequential(None)
        )
        .is_err()
    );
    let rev = [2.0, 1.0];
    let xr = Axis {
        label: "r",
        values: &rev,
    };
    assert!(
        heatmap(
            &out("hm_bad2.png"),
            "Bad",
            &xr,
            &y1,
            &[1.0, 2.0],
            "v",
            &CellMarks::default(),
            &Palette::Sequential(None)
        )
        .is_err()
    );
    assert!(
        heatmap(
            &out("hm_bad3.png"),
            "Bad",
            &x1,
            &y1,
            &[1.0],
            "v",
            &CellMarks::default(),
            &Palette::Sequential(Some((1.0, 1.0)))
        )
        .is_err()
    );
}

#[test]
fn histogram_bars() {
    let edges = linspace(-PI, PI, 37);
    let dens: Vec<f64> = edges
        .windows(2)
        .map(|w| (1.0 + (0.5 * (w[0] + w[1])).cos()) / (2.0 * PI))
        .collect();
    let p = out("histogram.png");
    histogram(
        &p,
        "Phase difference",
        &edges,
        &dens,
        "Δφ (rad)",
        "Density (1/rad)",
    )
    .unwrap();
    assert_not_blank(&p, 1000, 700, 5);
    assert!(histogram(&out("hist_bad.png"), "Bad", &edges[..3], &dens, "x", "y").is_err());
    assert!(histogram(&out("hist_empty.png"), "Bad", &[], &[], "x", "y").is_err());
    histogram(
        &out("hist_nan.png"),
        "NaN",
        &[0.0, 1.0, 2.0],
        &[f64::NAN, 0.0],
        "x",
        "y",
    )
    .unwrap();
}

#[test]
fn zero_one_and_scatter() {
    let n = 800;
    let (mut p, mut q) = (vec![0.0; n], vec![0.0; n]);
    let mut x = 0.3f64;
    for j in 1..n {
        x = 3.9 * x * (1.0 - x);
        p[j] = p[j - 1] + x * (1.7 * j as f64).cos();
        q[j] = q[j - 1] + x * (1.7 * j as f64).sin();
    }
    let c = linspace(0.5, 2.6, 100);
    let kc: Vec<f64> = c.iter().map(|c| 0.95 + 0.04 * (7.0 * c).sin()).collect();
    let path = out("zero_one.png");
    zero_one_figure(&path, &p, &q, &c, &kc, 0.98).unwrap();
    assert_not_blank(&path, 1400, 700, 10);
    zero_one_figure(&out("zero_one_nan.png"), &[], &[], &[], &[], f64::NAN).unwrap();
    assert!(zero_one_figure(&out("zo_bad.png"), &p, &q[..3], &c, &kc, 0.5).is_err());

    let t = linspace(0.0, 60.0, 3000);
    let th: Vec<f64> = t
        .iter()
        .map(|t| 0.2 * t.sin() + 0.05 * (3.1 * t).sin())
        .collect();
    let om: Vec<f64> = t
        .iter()
        .map(|t| 0.2 * t.cos() + 0.155 * (3.1 * t).cos())
        .collect();
    let path = out("phase.png");
    scatter(
        &path,
        "Phase portrait",
        "θ (rad)",
        "ω (rad/s)",
        &th,
        &om,
        true,
    )
    .unwrap();
    assert_not_blank(&path, 1000, 700, 5);
    // Bifurcation-like cloud of many dots.
    let (mut bx, mut by) = (vec![], vec![]);
    for i in 0..200 {
        let r = 2.8 + 1.2 * i as f64 / 199.0;
        let mut v = 0.5;
        for k in 0..300 {
            v = r * v * (1.0 - v);
            if k >= 200 {
                bx.push(r);
                by.push(v);
            }
        }
    }
    let path = out("bifurcation.png");
    scatter(&path, "Logistic map", "r (-)", "x (-)", &bx, &by, false).unwrap();
    assert_not_blank(&path, 1000, 700, 5);
    scatter(
        &out("scatter_empty.png"),
        "Empty",
        "x",
        "y",
        &[],
        &[],
        false,
    )
    .unwrap();
    assert!(scatter(&out("scatter_bad.png"), "Bad", "x", "y", &[1.0], &[], false).is_err());
}

#[test]
fn npy_roundtrip() {
    let data: Vec<f64> = (0..6).map(|i| i as f64 * 0.5 - 1.0).collect();
    let p = out("a.npy");
    write_npy_f64(&p, &[2, 3], &data).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = std::str::from_utf8(&bytes[10..10 + hlen]).unwrap();
    assert!(header.contains("'descr': '<f8'"), "{header}");
    assert!(header.contains("'fortran_order': False"), "{header}");
    let shape_txt = header
        .split("'shape': (")
        .nth(1)
        .and_then(|r| r.split(')').next())
        .unwrap();
    let shape: Vec<usize> = shape_txt
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().unwrap())
        .collect();
    assert_eq!(shape, vec![2, 3], "{header}");
    assert_eq!((10 + hlen) % 64, 0);
    let body = &bytes[10 + hlen..];
    assert_eq!(body.len(), 6 * 8);
    let back: Vec<f64> = body
        .chunks(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(back, data);
    assert!(write_npy_f64(&p, &[4, 2], &data).is_err());

    write_npy_f32(&out("b.npy"), &[3], &[1.0, 2.0, 3.5]).unwrap();
    write_npy_u8(&out("c.npy"), &[2, 2], &[0, 1, 1, 0]).unwrap();
    write_npy_i32(&out("d.npy"), &[1, 2, 1], &[-7, 9]).unwrap();

    // Cross-check with NumPy when available.
    let script = format!(
        "import numpy as np\n\
         a=np.load({a:?}); assert a.shape==(2,3) and a.dtype==np.float64 and a[1,2]==1.5, a\n\
         b=np.load({b:?}); assert b.dtype==np.float32 and b[2]==3.5\n\
         c=np.load({c:?}); assert c.dtype==np.uint8 and c[0,1]==1\n\
         d=np.load({d:?}); assert d.shape==(1,2,1) and d.dtype==np.int32 and d[0,0,0]==-7\n",
        a = p.to_str().unwrap(),
        b = out("b.npy").to_str().unwrap(),
        c = out("c.npy").to_str().unwrap(),
        d = out("d.npy").to_str().unwrap(),
    );
    let has_numpy = std::process::Command::new("python3")
        .args(["-c", "import numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_numpy {
        eprintln!("python3/numpy unavailable: skipping NumPy cross-check");
        return;
    }
    let o = std::process::Command::new("python3")
        .args(["-c", &script])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "numpy check failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn palettes_colour_like_their_kind_and_draw_a_bar_or_a_legend() {
    // Diverging: symmetric about 0 from the largest |value| of the valid cells, white at 0,
    // blue below, red above; failed cells magenta and missing values grey under every palette.
    let d = Palette::Diverging(None);
    let vals = [-2.0, 0.0, 5.0, f64::NAN];
    let range = d.range(&vals, &[false, false, false, false]);
    assert_eq!(range, (-5.0, 5.0));
    assert_eq!(d.range(&vals, &[false, false, true, false]), (-2.0, 2.0));
    let white = d.colour(0.0, false, range);
    assert!(white.0 > 240 && white.1 > 240 && white.2 > 240, "{white:?}");
    let blue = d.colour(-5.0, false, range);
    let red = d.colour(5.0, false, range);
    assert!(blue.2 > blue.0 && red.0 > red.2, "{blue:?} {red:?}");
    assert_eq!(
        d.colour(f64::NAN, false, range),
        pendulum_atlas_map::render::NODATA_COLOR
    );
    assert_eq!(
        d.colour(1.0, true, range),
        pendulum_atlas_map::render::INVALID_COLOR
    );
    assert_eq!(d.bar(64).len(), 64);
    // Categorical: a colour per listed value, anything else no data; the legend lists the
    // categories present among the valid cells.
    let cats = Palette::Categorical(vec![
        Category {
            value: 1.0,
            label: "one".into(),
            colour: RGBColor(1, 2, 3),
        },
        Category {
            value: 3.0,
            label: "three".into(),
            colour: RGBColor(4, 5, 6),
        },
    ]);
    let range = cats.range(&[1.0, 3.0], &[]);
    assert_eq!(cats.colour(3.0, false, range), RGBColor(4, 5, 6));
    assert_eq!(
        cats.colour(2.0, false, range),
        pendulum_atlas_map::render::NODATA_COLOR
    );
    assert!(cats.bar(64).is_empty());
    let present = cats.present(&[3.0, 3.0, 1.0], &[false, false, true]);
    assert_eq!(present.len(), 1);
    assert_eq!(present[0].label, "three");
    let xs = [1.0, 2.0];
    let ys = [1.0, 2.0, 3.0];
    let x = Axis {
        label: "x",
        values: &xs,
    };
    let y = Axis {
        label: "y",
        values: &ys,
    };
    let p = out("heatmap_categories.png");
    heatmap(
        &p,
        "Categories",
        &x,
        &y,
        &[1.0, 3.0, 3.0, 1.0, 2.0, 1.0],
        "regime",
        &CellMarks::default(),
        &cats,
    )
    .unwrap();
    let seen = colours(&p, 1000, 700);
    assert!(seen.contains(&[1, 2, 3]) && seen.contains(&[4, 5, 6]));
    let p = out("heatmap_diverging.png");
    heatmap(
        &p,
        "λ1",
        &x,
        &y,
        &[-1.0, 0.0, 2.0, 1.0, -3.0, 0.5],
        "λ1 (1/s)",
        &CellMarks::default(),
        &d,
    )
    .unwrap();
    assert_not_blank(&p, 1000, 700, 30);
}

#[test]
fn inferred_cells_are_hatched_and_named_in_the_legend() {
    let (xs, ys) = ([1.0, 2.0, 3.0], [1.0, 2.0]);
    let x = Axis {
        label: "x",
        values: &xs,
    };
    let y = Axis {
        label: "y",
        values: &ys,
    };
    let vals = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
    let draw = |name: &str, inferred: &[bool]| {
        let p = out(name);
        heatmap(
            &p,
            "marks",
            &x,
            &y,
            &vals,
            "v",
            &CellMarks {
                inferred,
                ..CellMarks::default()
            },
            &Palette::Sequential(None),
        )
        .unwrap();
        colours(&p, 1000, 700)
    };
    let plain = draw("heatmap_plain.png", &[]);
    let hatched = draw(
        "heatmap_hatched.png",
        &[true, false, true, false, false, false],
    );
    let new: Vec<_> = hatched.difference(&plain).collect();
    assert!(
        !new.is_empty(),
        "hatch lines and the legend swatch add colours"
    );
}

#[test]
fn a_picture_that_cannot_be_written_says_why_in_words() {
    let x = [0.0, 1.0, 2.0];
    let path = std::env::temp_dir()
        .join(format!("pendulum-atlas-no-such-dir-{}", std::process::id()))
        .join("chart.png");
    let e = pendulum_atlas_map::render::line_chart(
        &path,
        "t",
        "x",
        "y",
        &[pendulum_atlas_map::render::Series {
            name: "s",
            x: &x,
            y: &x,
        }],
        false,
        false,
    )
    .expect_err("no such folder")
    .to_string();
    assert!(e.contains("No such file or directory"), "{e}");
    for debug in ["ImageError", "IoError", "Custom {", "kind:"] {
        assert!(!e.contains(debug), "Debug formatting in: {e}");
    }
}
