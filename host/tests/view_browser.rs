//! The plan page in a real browser: headless Chromium (Debian's `chromium`, installed by
//! scripts/test-all.sh) driven over the Chrome DevTools protocol. The page must load with no
//! JavaScript error, draw one arm per robot, follow the time slider with the solution's joint
//! angles (read back from the drawn meshes' frames), and mark the links of a collision.

mod common;

use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use base64::Engine;
use serde_json::{json, Value};
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

use omcbsa::demo::{box_flip, STEPS};
use omcbsa::view::write_html;

/// Most polls of a page that is not ready yet, 100 ms apart (a bound, not a timing claim).
const MAX_POLLS: usize = 1200;

/// A headless Chromium with one page, over the DevTools protocol (flattened sessions).
struct Browser {
    child: Child,
    ws: WebSocket<MaybeTlsStream<TcpStream>>,
    session: String,
    next_id: u64,
    events: Vec<Value>,
    _profile: tempfile::TempDir,
}

impl Browser {
    fn start() -> Browser {
        let exe = ["chromium", "chromium-browser"]
            .into_iter()
            .find(|c| {
                Command::new(c)
                    .arg("--version")
                    .output()
                    .is_ok_and(|o| o.status.success())
            })
            .expect(
                "no chromium on PATH: scripts/test-all.sh installs it (apt-get install chromium)",
            );
        let profile = tempfile::tempdir().unwrap();
        let mut child = Command::new(exe)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                // WebGL on the CPU (no GPU in CI).
                "--use-angle=swiftshader",
                "--enable-unsafe-swiftshader",
                "--window-size=1280,800",
                "--remote-debugging-port=0",
            ])
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg("about:blank")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("cannot start chromium");
        let stderr = BufReader::new(child.stderr.take().unwrap());
        let mut url = None;
        let mut seen = Vec::new();
        for line in stderr.lines() {
            let line = line.unwrap();
            if let Some(u) = line.strip_prefix("DevTools listening on ") {
                url = Some(u.trim().to_string());
                break;
            }
            seen.push(line);
        }
        let url = url
            .unwrap_or_else(|| panic!("chromium gave no DevTools address:\n{}", seen.join("\n")));
        let (ws, _) = tungstenite::connect(url.as_str()).expect("cannot reach chromium's DevTools");
        let mut browser = Browser {
            child,
            ws,
            session: String::new(),
            next_id: 0,
            events: Vec::new(),
            _profile: profile,
        };
        let target = browser.call("Target.createTarget", json!({"url": "about:blank"}));
        let target = target["targetId"].as_str().unwrap().to_string();
        let attached = browser.call(
            "Target.attachToTarget",
            json!({"targetId": target, "flatten": true}),
        );
        browser.session = attached["sessionId"].as_str().unwrap().to_string();
        for domain in ["Runtime.enable", "Log.enable", "Page.enable"] {
            browser.call(domain, json!({}));
        }
        browser
    }

    /// Sends a command (to the page once attached) and waits for its answer, keeping events.
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        let mut msg = json!({"id": id, "method": method, "params": params});
        if !self.session.is_empty() {
            msg["sessionId"] = json!(self.session);
        }
        self.ws.send(Message::text(msg.to_string())).unwrap();
        loop {
            let Message::Text(text) = self.ws.read().unwrap() else {
                continue;
            };
            let v: Value = serde_json::from_str(&text).unwrap();
            if v["id"] == json!(id) {
                assert!(v.get("error").is_none(), "{method} failed: {}", v["error"]);
                return v["result"].clone();
            }
            self.events.push(v);
        }
    }

    /// Evaluates a JavaScript expression in the page and returns its value.
    fn eval(&mut self, expression: &str) -> Value {
        let r = self.call(
            "Runtime.evaluate",
            json!({"expression": expression, "returnByValue": true, "awaitPromise": true}),
        );
        assert!(
            r.get("exceptionDetails").is_none(),
            "{expression}: {}",
            r["exceptionDetails"]
        );
        r["result"]["value"].clone()
    }

    /// Opens `page` and waits until the viewer says it is ready or failed.
    fn open(&mut self, page: &Path) {
        self.call(
            "Page.navigate",
            json!({"url": format!("file://{}", page.display())}),
        );
        for _ in 0..MAX_POLLS {
            let state = self
                .eval("window.omcbsaView ? (omcbsaView.ready ? 'ready' : omcbsaView.error) : null");
            match state.as_str() {
                Some("ready") => return,
                Some(error) => panic!("the viewer failed: {error}\nevents: {:?}", self.errors()),
                None => std::thread::sleep(Duration::from_millis(100)),
            }
        }
        panic!("the viewer never got ready; errors: {:?}", self.errors());
    }

    /// JavaScript errors the page logged: exceptions, console.error, error log entries.
    fn errors(&self) -> Vec<String> {
        self.events
            .iter()
            .filter_map(|e| match e["method"].as_str()? {
                "Runtime.exceptionThrown" => Some(e["params"]["exceptionDetails"].to_string()),
                "Runtime.consoleAPICalled" if e["params"]["type"] == "error" => {
                    Some(e["params"]["args"].to_string())
                }
                "Log.entryAdded" if e["params"]["entry"]["level"] == "error" => {
                    Some(e["params"]["entry"].to_string())
                }
                _ => None,
            })
            .collect()
    }

    fn screenshot(&mut self, path: &Path) {
        let shot = self.call("Page.captureScreenshot", json!({"format": "png"}));
        let png = base64::engine::general_purpose::STANDARD
            .decode(shot["data"].as_str().unwrap())
            .unwrap();
        assert!(png.starts_with(b"\x89PNG"), "not a PNG");
        std::fs::write(path, png).unwrap();
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Same angle up to whole turns.
fn same_angle(a: f64, b: f64) -> bool {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d) < 1e-4
}

#[test]
fn demo_page_plays_the_solution_in_chromium() {
    let demo = box_flip().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("plan.html");
    write_html(&demo.problem, Some(&demo.witness), None, &page).unwrap();
    let size = std::fs::metadata(&page).unwrap().len();
    assert!(size < 5_000_000, "the page is {size} bytes");

    let mut browser = Browser::start();
    browser.open(&page);
    assert_eq!(
        browser.eval("omcbsaView.arms()"),
        json!(demo.problem.robots.len())
    );
    assert_eq!(browser.eval("omcbsaView.steps"), json!(STEPS));

    let paths = demo.witness.joint_paths.as_ref().unwrap();
    let angles = |browser: &mut Browser| -> Vec<Vec<f64>> {
        serde_json::from_value(browser.eval("omcbsaView.jointAngles()")).unwrap()
    };
    let before = angles(&mut browser);
    let t = 17;
    let step = browser.eval(&format!(
        "(() => {{ const s = document.getElementById('slider'); s.value = '{t}'; \
         s.dispatchEvent(new Event('input')); return omcbsaView.step(); }})()"
    ));
    assert_eq!(step, json!(t));
    assert!(browser
        .eval("document.getElementById('counter').textContent")
        .as_str()
        .unwrap()
        .starts_with(&format!("step {t} /")));
    let after = angles(&mut browser);
    assert_eq!(after.len(), paths.len());
    for (i, (drawn, path)) in after.iter().zip(paths).enumerate() {
        assert_eq!(drawn.len(), 7);
        for (j, (&a, &q)) in drawn.iter().zip(&path[t]).enumerate() {
            assert!(
                same_angle(a, q),
                "robot {i} joint {j} at step {t}: drawn {a}, planned {q}"
            );
        }
        for (j, (&a, &q)) in before[i].iter().zip(&path[0]).enumerate() {
            assert!(
                same_angle(a, q),
                "robot {i} joint {j} at step 0: drawn {a}, planned {q}"
            );
        }
    }
    assert_ne!(before, after, "the slider changed nothing");

    browser.eval("document.getElementById('capsules').click()");
    let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plan-view-demo.png");
    browser.screenshot(&shot);
    assert!(
        std::fs::metadata(&shot).unwrap().len() > 20_000,
        "a blank screenshot"
    );
    assert_eq!(
        browser.errors(),
        Vec::<String>::new(),
        "the page logged JavaScript errors"
    );
}

#[test]
fn invalid_solution_page_marks_the_clashing_links() {
    // The arm folded onto itself: its wrist hits its upper arm at every step.
    let (problem, solution) = common::one_robot(&[common::FOLDED; 3], 0.1);
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("invalid.html");
    write_html(&problem, Some(&solution), None, &page).unwrap();

    let mut browser = Browser::start();
    browser.open(&page);
    assert_eq!(browser.eval("omcbsaView.arms()"), json!(1));
    browser.eval("omcbsaView.setStep(1)");
    let marked: Vec<(usize, String)> =
        serde_json::from_value(browser.eval("omcbsaView.marked()")).unwrap();
    assert!(marked.len() >= 2, "marked {marked:?}");
    assert!(marked.iter().all(|(r, _)| *r == 0));
    let clash = browser.eval("document.getElementById('clash').textContent");
    let clash = clash.as_str().unwrap();
    assert!(
        clash.starts_with("step 1: ") && clash.contains("hits its own link"),
        "{clash}"
    );
    for (_, link) in &marked {
        assert!(
            clash.contains(link.as_str()),
            "{link} marked but not named in {clash}"
        );
    }
    let status = browser.eval("document.getElementById('status').textContent");
    assert!(status.as_str().unwrap().contains("invalid"), "{status}");
    browser.screenshot(&Path::new(env!("CARGO_TARGET_TMPDIR")).join("plan-view-invalid.png"));
    assert_eq!(
        browser.errors(),
        Vec::<String>::new(),
        "the page logged JavaScript errors"
    );
}

/// Issue 22: the page plays the approach before the path. The slider covers both, the
/// counter names the approach, frame 0 is `initial` and frame `lead` the path's step 0, and a
/// finding in the approach is shown at its frame.
#[test]
fn the_approach_is_played_before_the_path() {
    use omcbsa::online::policy::RETRACT;
    let mut problem = box_flip().unwrap().problem;
    for r in &mut problem.robots {
        r.initial = Some(RETRACT.to_vec());
    }
    let solution =
        omcbsa::plan::plan_file(&problem, omcbsa::planners::PlannerKind::OmCbsa, 10.0).unwrap();
    let approach = solution.approach.clone().expect("an approach from initial");
    let a = approach[0].len();
    assert!(a > 2, "the arms stand folded away from the box");
    // A broken approach: robot 1 jumps at its configuration a / 2.
    let mut broken = solution.clone();
    broken.approach.as_mut().unwrap()[1][a / 2][0] += 0.5;
    let dir = tempfile::tempdir().unwrap();
    let (good, bad) = (dir.path().join("good.html"), dir.path().join("bad.html"));
    write_html(&problem, Some(&solution), None, &good).unwrap();
    write_html(&problem, Some(&broken), None, &bad).unwrap();

    let mut browser = Browser::start();
    browser.open(&good);
    assert_eq!(browser.eval("omcbsaView.lead"), json!(a + 1));
    assert_eq!(browser.eval("omcbsaView.steps"), json!(a + 1 + STEPS));
    let angles = |browser: &mut Browser, t: usize| -> Vec<Vec<f64>> {
        browser.eval(&format!("omcbsaView.setStep({t})"));
        serde_json::from_value(browser.eval("omcbsaView.jointAngles()")).unwrap()
    };
    let counter = |browser: &mut Browser| -> String {
        let c = browser.eval("document.getElementById('counter').textContent");
        c.as_str().unwrap().to_string()
    };
    let paths = solution.joint_paths.as_ref().unwrap();
    for (t, expect) in [(0, RETRACT.to_vec()), (a + 1, paths[0][0].clone())] {
        let drawn = angles(&mut browser, t);
        for (j, (&d, &q)) in drawn[0].iter().zip(&expect).enumerate() {
            assert!(
                same_angle(d, q),
                "frame {t} joint {j}: drawn {d}, planned {q}"
            );
        }
    }
    angles(&mut browser, 1);
    assert!(counter(&mut browser).starts_with(&format!("approach 1 / {}", a + 1)));
    angles(&mut browser, a + 3);
    assert!(counter(&mut browser).starts_with("step 2 /"));
    let phase = browser.eval("document.getElementById('phase').textContent");
    assert!(phase.as_str().unwrap().starts_with("approach"), "{phase}");

    browser.open(&bad);
    let first = browser.eval(
        "(() => { const li = document.getElementById('violations').children[0]; li.click(); \
         return [li.textContent, omcbsaView.step()]; })()",
    );
    let text = first[0].as_str().unwrap();
    assert!(text.contains("approach step"), "{text}");
    let frame = first[1].as_u64().unwrap() as usize;
    assert!(
        frame > 0 && frame <= a + 1,
        "a finding in the approach at frame {frame}"
    );
    assert_eq!(
        browser.errors(),
        Vec::<String>::new(),
        "the page logged JavaScript errors"
    );
}

#[test]
fn a_mixed_fleet_is_drawn_each_arm_with_its_own_model() {
    use omcbsa::format::RobotSpec;
    use omcbsa::models::{Fleet, ModelKind};
    use omcbsa::plan::plan_file;
    use omcbsa::planners::PlannerKind;
    use omcbsa_core::model::Models;
    // A Gen3 and a Panda 1.2 m apart, each hand where its own arm's slow motion puts it.
    let homes = [
        ("kinova_gen3", common::Q0),
        (
            "franka_panda",
            [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785],
        ),
    ];
    let mut robots = Vec::new();
    let mut trajectories = Vec::new();
    for (i, (model, home)) in homes.into_iter().enumerate() {
        let id = ModelKind::parse(model).unwrap().id();
        let base = common::at([1.2 * i as f64, 0.0, 0.0]);
        let frame = omcbsa::pose::to_frame(&base).unwrap();
        let poses = (0..6)
            .map(|t| home.map(|v| v + 0.04 * t as f64))
            .map(|q| omcbsa::pose::from_frame(&frame.compose(&Fleet::fk(id, &q))))
            .collect();
        trajectories.push(omcbsa::format::TrajectorySpec {
            name: format!("hand_{i}"),
            poses,
        });
        robots.push(RobotSpec {
            model: model.to_string(),
            ..common::robot(model, base, None)
        });
    }
    let problem = common::problem(robots, trajectories, 0.1);
    let solution = plan_file(&problem, PlannerKind::OmCbsa, 10.0).unwrap();
    let paths = solution.joint_paths.clone().expect("solved");
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("mixed.html");
    write_html(&problem, Some(&solution), None, &page).unwrap();
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("\"panda_link3\":") && html.contains("\"forearm_link\":"));
    let screenshot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plan-view-mixed.png");

    let mut browser = Browser::start();
    browser.open(&page);
    assert_eq!(browser.eval("omcbsaView.arms()"), json!(2));
    // Each arm with its own model's meshes: the Gen3's 8, the Panda's 9 (links 0-7, hand).
    assert_eq!(
        browser.eval("omcbsaView.models()"),
        json!([["kinova_gen3", 8], ["franka_panda", 9]])
    );
    let text = browser.eval("document.body.textContent");
    let text = text.as_str().unwrap();
    assert!(
        text.contains("Kinova") && text.contains("Apache License"),
        "licences missing"
    );
    // The drawn joint angles, read back through each arm's own model's joints.
    let drawn: Vec<Vec<f64>> =
        serde_json::from_value(browser.eval("omcbsaView.jointAngles()")).unwrap();
    for (i, (drawn, path)) in drawn.iter().zip(&paths).enumerate() {
        assert_eq!(drawn.len(), 7);
        for (j, (&a, &q)) in drawn.iter().zip(&path[0]).enumerate() {
            assert!(
                same_angle(a, q),
                "robot {i} joint {j}: drawn {a}, planned {q}"
            );
        }
    }
    browser.screenshot(&screenshot);
    assert_eq!(browser.errors(), Vec::<String>::new());
}
