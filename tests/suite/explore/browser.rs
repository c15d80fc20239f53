//! The page in a real browser (Debian's Chromium through ChromeDriver, driven by WebDriver):
//! the heat map's pixels are the colours of the stored values, and a click on a cell shows
//! its motion with the K, R and period that `simulate` gives on the cell's downloaded scene.
//!
//! Skips with a message when `/usr/bin/chromedriver` is absent, unless
//! `PENDULUM_ATLAS_REQUIRE_BROWSER=1` (as `.ci/run` sets), where it fails instead.
//! `PENDULUM_ATLAS_SCREENSHOT=PATH` also saves the page after the click to PATH (the README's
//! picture).

use super::{Server, npy, request, scratch, simulate, small_map};
use fantoccini::actions::{InputSource, MOUSE_BUTTON_LEFT, MouseActions, PointerAction};
use fantoccini::{Client, ClientBuilder, Locator};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_map::render::cell_colour;
use serde_json::json;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

const CHROMEDRIVER: &str = "/usr/bin/chromedriver";
const CHROMIUM: &str = "/usr/bin/chromium";

/// ChromeDriver on a free port, stopped when dropped.
struct Driver(Child, u16);

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start_driver() -> Option<Driver> {
    if !Path::new(CHROMEDRIVER).exists() || !Path::new(CHROMIUM).exists() {
        let msg = "explore browser test: no /usr/bin/chromedriver or /usr/bin/chromium \
                   (apt-get install chromium chromium-driver)";
        if std::env::var("PENDULUM_ATLAS_REQUIRE_BROWSER").as_deref() == Ok("1") {
            panic!("{msg}, and PENDULUM_ATLAS_REQUIRE_BROWSER=1");
        }
        eprintln!("skipped: {msg}");
        return None;
    }
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let driver = Driver(
        Command::new(CHROMEDRIVER)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
        port,
    );
    for _ in 0..100 {
        if std::net::TcpStream::connect(("127.0.0.1", port)).is_ok() {
            return Some(driver);
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    panic!("chromedriver did not listen on port {port} within 10 s");
}

async fn browser(driver: &Driver, profile: &Path) -> Client {
    let args = [
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--force-device-scale-factor=1",
        "--window-size=1500,1650",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain([format!("--user-data-dir={}", profile.display())])
    .collect::<Vec<_>>();
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        json!({ "binary": CHROMIUM, "args": args }),
    );
    ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
        .capabilities(caps)
        .connect(&format!("http://127.0.0.1:{}", driver.1))
        .await
        .expect("a WebDriver session")
}

/// The colour of canvas pixel (x, y) in a PNG screenshot of the canvas element.
fn pixel(png: &[u8], x: f64, y: f64) -> [u8; 3] {
    let img = image::load_from_memory(png).unwrap().to_rgb8();
    let p = img.get_pixel(x.round() as u32, y.round() as u32);
    [p[0], p[1], p[2]]
}

/// Centre of page cell (ix, iy) in canvas pixels, from the page's own layout.
async fn centre(c: &Client, ix: usize, iy: usize) -> (f64, f64) {
    let r = c
        .execute(
            "return atlas.cellRect(arguments[0], arguments[1]);",
            vec![json!(ix), json!(iy)],
        )
        .await
        .unwrap();
    let v = |k: &str| r[k].as_f64().unwrap();
    (v("x") + v("w") / 2.0, v("y") + v("h") / 2.0)
}

#[test]
fn the_page_paints_the_map_and_a_click_shows_the_cell_as_simulate_runs_it() {
    let Some(driver) = start_driver() else { return };
    let dir = small_map();
    let server = Server::start(dir, &[]);
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let profile = scratch("chromium-profile");
        let c = browser(&driver, &profile).await;
        let outcome = drive(&c, &server, dir).await;
        let _ = c.close().await;
        outcome
    });
}

async fn drive(c: &Client, server: &Server, dir: &Path) {
    c.goto(&format!("{}/", server.url)).await.unwrap();
    c.wait()
        .at_most(Duration::from_secs(30))
        .for_element(Locator::Css("#map[data-ready='1'][data-metric='regime']"))
        .await
        .expect("the page opens on the verdict");
    // Switch to K as a user does, with the metric menu.
    c.execute(
        "const m = document.getElementById('metric'); m.value = 'K'; \
         m.dispatchEvent(new Event('change'));",
        vec![],
    )
    .await
    .unwrap();
    let canvas = c
        .wait()
        .at_most(Duration::from_secs(30))
        .for_element(Locator::Css("#map[data-metric='K']"))
        .await
        .expect("the K map is drawn");
    // K is drawn over its fixed range 0..1, failed cells in the failure colour.
    let (k, status) = (npy(dir, "K"), npy_status(dir));
    let png = canvas.screenshot().await.unwrap();
    for (ix, iy) in [(0, 0), (5, 0), (0, 3), (5, 3), (2, 1), (3, 2)] {
        let cell = ix * 4 + iy;
        let (x, y) = centre(c, ix, iy).await;
        let want = cell_colour(k[cell], status[cell] != Status::Ok.code(), (0.0, 1.0));
        let got = pixel(&png, x, y);
        let close = got
            .iter()
            .zip([want.0, want.1, want.2])
            .all(|(a, b)| a.abs_diff(b) <= 2);
        assert!(
            close,
            "cell ({ix}, {iy}) = {cell}: K = {}, pixel {got:?}, colour {want:?}",
            k[cell]
        );
    }
    // Click cell (2, 1) and wait for its run.
    let (ix, iy) = (2, 1);
    let cell = ix * 4 + iy;
    let (x, y) = centre(c, ix, iy).await;
    let (w, h) = canvas.rectangle().await.map(|r| (r.2, r.3)).unwrap();
    let click = MouseActions::new("mouse".into())
        .then(PointerAction::MoveToElement {
            element: canvas.clone(),
            duration: None,
            x: x - w / 2.0,
            y: y - h / 2.0,
        })
        .then(PointerAction::Down {
            button: MOUSE_BUTTON_LEFT,
        })
        .then(PointerAction::Up {
            button: MOUSE_BUTTON_LEFT,
        });
    c.perform_actions(click).await.unwrap();
    c.wait()
        .at_most(Duration::from_secs(120))
        .for_element(Locator::Css("#cellState[data-state='done']"))
        .await
        .expect("the clicked cell's run finishes in the page");
    let title = c
        .find(Locator::Id("cellTitle"))
        .await
        .unwrap()
        .text()
        .await
        .unwrap();
    assert!(title.starts_with(&format!("Cell {cell}:")), "{title}");
    let alpha = c
        .find(Locator::Id("chartAlpha"))
        .await
        .unwrap()
        .screenshot()
        .await
        .unwrap();
    let img = image::load_from_memory(&alpha).unwrap().to_rgb8();
    let drawn = img
        .pixels()
        .filter(|p| p[0] < 80 && p[2] > 130 && p[1] < 130)
        .count();
    assert!(
        drawn > 200,
        "α(t) drawn in the page ({drawn} pixels of its colour)"
    );
    if let Ok(path) = std::env::var("PENDULUM_ATLAS_SCREENSHOT") {
        std::fs::write(&path, c.screenshot().await.unwrap()).unwrap();
    }
    // The values shown are simulate's on the downloaded scene.
    let shown = |id: &'static str| async move {
        let e = c.find(Locator::Id(id)).await.unwrap();
        e.attr("data-value")
            .await
            .unwrap()
            .unwrap()
            .parse::<f64>()
            .unwrap()
    };
    let (pk, pr, pp) = (
        shown("sim-K").await,
        shown("sim-R").await,
        shown("sim-period").await,
    );
    let href = c
        .find(Locator::Id("download"))
        .await
        .unwrap()
        .attr("href")
        .await
        .unwrap()
        .unwrap();
    let (st, toml) = request(server, "GET", &href);
    assert_eq!(st, 200);
    let work = scratch("browser-cell");
    std::fs::create_dir_all(&work).unwrap();
    std::fs::write(work.join("cell.toml"), toml).unwrap();
    let (sk, sr, sp) = simulate(&work.join("cell.toml"), &work.join("sim"));
    assert_eq!(
        (Some(pk), Some(pr), Some(pp)),
        (sk, sr, sp),
        "page vs simulate on the downloaded scene"
    );
    let map_k = shown("map-K").await;
    assert_eq!(map_k, k[cell], "the map's K shown for the cell");
}

fn npy_status(dir: &Path) -> Vec<u8> {
    let bytes = std::fs::read(dir.join("status.npy")).unwrap();
    npyz::NpyFile::new(&bytes[..]).unwrap().into_vec().unwrap()
}

/// A map from several starts per cell: the page lists a cell's attractors, and a button runs
/// the start that reached one of them.
#[test]
fn the_page_lists_a_cells_attractors_and_runs_each() {
    let Some(driver) = start_driver() else { return };
    let out = scratch("browser-starts-map");
    crate::map_cli(&out, &crate::STARTS_MAP_SETS);
    let server = Server::start(&out, &[]);
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let profile = scratch("chromium-profile-starts");
        let c = browser(&driver, &profile).await;
        c.goto(&format!("{}/", server.url)).await.unwrap();
        c.wait()
            .at_most(Duration::from_secs(30))
            .for_element(Locator::Css("#map[data-ready='1']"))
            .await
            .expect("the map is drawn");
        c.execute("atlas.runCell(1);", vec![]).await.unwrap();
        let done = Locator::Css("#cellState[data-state='done']");
        c.wait()
            .at_most(Duration::from_secs(120))
            .for_element(done)
            .await
            .unwrap();
        let items = c.find_all(Locator::Css("#attractorList li")).await.unwrap();
        assert_eq!(items.len(), 2, "both wells' attractors listed");
        let button = items[1].find(Locator::Css("button")).await.unwrap();
        let label = button.text().await.unwrap();
        let start: usize = label.trim_start_matches("Run start ").parse().unwrap();
        button.click().await.unwrap();
        // The run of that start replaces the first one's result when it is done.
        let want = format!("run as start {start}:");
        let mut info = String::new();
        for _ in 0..480 {
            info = c
                .find(Locator::Id("runInfo"))
                .await
                .unwrap()
                .text()
                .await
                .unwrap();
            if info.starts_with(&want) {
                break;
            }
            tokio::time::sleep(Duration::from_millis(250)).await;
        }
        assert!(info.starts_with(&want), "{info}");
        let _ = c.close().await;
    });
}
