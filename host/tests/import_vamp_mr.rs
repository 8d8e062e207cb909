//! `omcbsa import-problems vamp-mr` on a checkout this test writes: files in VAMP-MR's
//! formats (an SRDF, the environment factory's C++, a base-transform file) with made-up
//! scenes, not VAMP-MR's. What it imports, what it leaves out and why, and the errors that
//! name the file and what in it is wrong.

use std::path::Path;

use omcbsa::format::ShapeKind;
use omcbsa::import::vamp_mr::{import, parse_transforms, Assignment, Options};
use omcbsa::load;
use omcbsa::models::{Fleet, ModelKind};
use omcbsa::plan::load_problem;
use omcbsa::pose::to_frame;
use omcbsa::suite::read_index;
use omcbsa_core::model::Models;

/// The environment factory, in the shape of VAMP-MR's `vamp_env_factory.cpp`.
const FACTORY: &str = r#"
#include <array>
namespace vamp_env
{
namespace
{
    Object make_box_object(const std::string &name, double x, double y, double z,
                           double length, double width, double height)
    {
        Object obj;
        return obj;
    }

    void add_panda_table_segments(PlanInstance &instance, const std::string &prefix)
    {
        struct Segment { double x; double y; double z; double length; double width; double height; };
        const std::array<Segment, 2> segments = {{{0.0, 0.9, 0.05, 2.0, 0.4, 0.1},
                                                  {0.0, -0.9, 0.05, 2.0, 0.4, 0.1}}};
        for (std::size_t i = 0; i < segments.size(); ++i)
        {
            instance.addMoveableObject(make_box_object(prefix, segments[i].x, 0, 0, 0, 0, 0));
        }
    }

    void add_panda_four_table_segments(PlanInstance &instance, const std::string &prefix)
    {
        const double z = 0.05;
        const double thickness = 0.1;
        const std::array<std::array<double, 4>, 1> segments = {{{0.0, 1.2, 2.0, 0.2}}};
    }

    void add_hollow_box_obstacles(PlanInstance &instance, const std::string &prefix,
                                  const Eigen::Vector3d &center, const Eigen::Vector3d &size,
                                  double thickness = 0.02)
    {
    }

    void add_cylinder_attachment(PlanInstance &instance, int robot_id, const std::string &name,
                                 double radius, double length, const Eigen::Vector3d &translation,
                                 const Eigen::Quaterniond &orientation)
    {
    }
}  // namespace

std::optional<EnvironmentConfig> make_environment_config(const std::string &name)
{
    if (name == "two_gp")
    {
        return EnvironmentConfig{name, "dual_arms", {"left_arm", "right_arm"}, {}, VampVariant::DualGp4, {}, std::nullopt};
    }
    if (name == "two")
    {
        return EnvironmentConfig{name, "panda_multi_arm", {"panda0_arm", "panda1_arm"},
                                 {"panda0_hand", "panda1_hand"}, VampVariant::PandaPair, {}, std::nullopt};
    }
    if (name == "four")
    {
        return EnvironmentConfig{name, "panda_multi_arm", {"panda0_arm", "panda1_arm", "panda2_arm", "panda3_arm"},
                                 {}, VampVariant::PandaQuad, {}, std::nullopt};
    }
    return std::nullopt;
}

void add_environment_obstacles(const EnvironmentConfig &config, PlanInstance &instance)
{
    if (config.environment_name == "two")
    {
        add_panda_table_segments(instance, "two_table");
    }
    else if (config.environment_name == "four")
    {
        add_panda_four_table_segments(instance, "four_table");
        const std::array<Eigen::Vector3d, 1> centers = {Eigen::Vector3d(0.0, 0.0, 0.0)};
        const Eigen::Vector3d size(0.3, 0.3, 0.2);
        for (std::size_t i = 0; i < centers.size(); ++i)
        {
            add_hollow_box_obstacles(instance, "bin_" + std::to_string(i), centers[i], size);
        }
    }
}

void add_environment_attachments(const EnvironmentConfig &config, PlanInstance &instance)
{
    if (config.environment_name == "two")
    {
        const Eigen::Quaterniond rod_orientation = quaternion_from_rpy(0.0, M_PI_2, 0.0);
        add_cylinder_attachment(instance, 1, "panda1_rod", 0.01, 0.2, Eigen::Vector3d(0.0, 0.0, -0.005), rod_orientation);
    }
}

std::optional<std::vector<Eigen::Isometry3d>> default_base_transforms(const EnvironmentConfig &config)
{
    switch (*config.vamp_variant)
    {
    case VampVariant::PandaQuad:
    {
        if (config.environment_name == "four")
        {
            const std::array<double, 4> yaws = {M_PI_4, 3.0 * M_PI_4, -3.0 * M_PI_4, -M_PI_4};
            const std::array<Eigen::Vector3d, 4> translations = {
                Eigen::Vector3d(-0.5, -0.5, 0.1), Eigen::Vector3d(0.5, -0.5, 0.1),
                Eigen::Vector3d(0.5, 0.5, 0.1), Eigen::Vector3d(-0.5, 0.5, 0.1)};
            for (std::size_t i = 0; i < yaws.size(); ++i)
            {
                const Eigen::AngleAxisd rotation(yaws[i], Eigen::Vector3d::UnitZ());
            }
            return transforms;
        }
        return std::nullopt;
    }
    }
    return std::nullopt;
}
}  // namespace vamp_env
"#;

/// Two arms 1.2 m apart, facing each other.
const PAIR_BASES: &str = r#"[
  {"translation": [0.6, 0.0, 0.1], "rpy": [0.0, 0.0, 3.141592653589793]},
  {"translation": [-0.6, 0.0, 0.1], "rpy": [0.0, 0.0, 0.0]}
]"#;

const READY: [f64; 7] = [0.0, -0.5, 0.0, -2.0, 0.0, 1.6, 0.78];
const LEANING: [f64; 7] = [0.4, 0.2, 0.0, -1.8, 0.0, 2.0, 0.78];
/// Joint 4 at 0: within VAMP's Panda limits, outside ours (upper -0.0698).
const STRAIGHT: [f64; 7] = [0.0, 0.0, 0.0, 0.0, 0.0, 1.6, 0.78];

fn group(prefix: &str) -> String {
    let joints: String = (1..=8)
        .map(|k| format!("<joint name=\"{prefix}_joint{k}\"/>"))
        .collect();
    format!("<group name=\"{prefix}_arm\">{joints}</group>")
}

fn state(name: &str, arms: &[(&str, [f64; 7])]) -> String {
    let joints: String = (arms.iter())
        .flat_map(|(p, q)| {
            (q.iter().enumerate())
                .map(move |(k, v)| format!("<joint name=\"{p}_joint{}\" value=\"{v}\"/>", k + 1))
        })
        .collect();
    format!("<group_state name=\"{name}\" group=\"panda_multi_arm\">{joints}</group_state>")
}

fn srdf(arms: &[&str], states: &[String]) -> String {
    let groups: String = arms.iter().map(|a| group(a)).collect();
    format!(
        "<?xml version=\"1.0\"?>\n<robot name=\"panda\">{groups}<group name=\"panda_multi_arm\"/>\n{}\n</robot>\n",
        states.join("\n")
    )
}

/// A checkout with environments `two` (2 Pandas, 3 poses, one out of our limits), `four`
/// (4 Pandas, 2 poses) and `two_gp` (not Pandas).
fn checkout(dir: &Path) {
    let core = dir.join("mr_planner_core");
    for d in ["src/backends", "config/srdf", "scripts/plugins/config"] {
        std::fs::create_dir_all(core.join(d)).unwrap();
    }
    std::fs::write(core.join("src/backends/vamp_env_factory.cpp"), FACTORY).unwrap();
    let pair = |a, b| [("panda0", a), ("panda1", b)];
    let two = srdf(
        &["panda0", "panda1"],
        &[
            state("ready", &pair(READY, READY)),
            state("lean", &pair(LEANING, READY)),
            state("straight", &pair(STRAIGHT, READY)),
        ],
    );
    std::fs::write(core.join("config/srdf/two.srdf"), two).unwrap();
    let arms = ["panda0", "panda1", "panda2", "panda3"];
    let all = |q| arms.map(|a| (a, q));
    let four = srdf(
        &arms,
        &[state("ready", &all(READY)), state("lean", &all(LEANING))],
    );
    std::fs::write(core.join("config/srdf/four.srdf"), four).unwrap();
    std::fs::write(core.join("config/srdf/two_gp.srdf"), srdf(&["left"], &[])).unwrap();
    std::fs::write(
        core.join("scripts/plugins/config/panda_two_base_transforms.json"),
        PAIR_BASES,
    )
    .unwrap();
}

fn options(envs: &[&str]) -> Options {
    Options {
        environments: envs.iter().map(|e| e.to_string()).collect(),
        ..Options::default()
    }
}

#[test]
fn imports_every_usable_pose_pair_with_scene_rods_and_fixed_assignment() {
    let dir = tempfile::tempdir().unwrap();
    checkout(dir.path());
    let out = dir.path().join("suite");
    let report = import(dir.path(), &out, &options(&["two", "four", "two_gp"])).unwrap();

    let [two, four] = &report.environments[..] else {
        panic!("two environments imported: {report:?}")
    };
    assert_eq!(two.poses, ["ready", "lean"]);
    let [(pose, why)] = &two.left_out[..] else {
        panic!("one pose left out: {two:?}")
    };
    assert_eq!(pose, "straight");
    assert!(
        why.contains("robots[0].initial[3]") && why.contains("outside the limits"),
        "{why}"
    );
    assert_eq!((two.problems, two.obstacles, two.rods), (2, 2, 1));
    assert_eq!(
        (four.robots, four.problems, four.obstacles, four.rods),
        (4, 2, 6, 0)
    );
    let [(env, why)] = &report.not_imported[..] else {
        panic!("two_gp not imported: {report:?}")
    };
    assert_eq!(env, "two_gp");
    assert!(
        why.contains("VampVariant::DualGp4, not Franka Pandas"),
        "{why}"
    );
    assert!(
        report
            .markdown()
            .contains("| two | 2 | 2 | 1 | 2 | 1 | 2 |"),
        "{}",
        report.markdown()
    );

    let index = read_index(&out).unwrap();
    let names: Vec<&str> = index.problems.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "two_ready_to_lean",
            "two_lean_to_ready",
            "four_ready_to_lean",
            "four_lean_to_ready"
        ]
    );
    let panda = ModelKind::parse("franka_panda").unwrap().id();
    for entry in &index.problems {
        assert_eq!(entry.family, entry.name.split('_').next().unwrap());
        assert_eq!(entry.horizon, 1);
        assert_eq!(
            entry.assignment,
            Some((0..entry.robots).map(Some).collect())
        );
        let text = load::read_text(&out.join(&entry.file)).unwrap();
        let file = load::parse_problem(&text).unwrap();
        // Every problem loads, its arms clear where they start.
        load_problem(&file).unwrap();
        assert_eq!(file.dt, 0.1);
        for (r, t) in file.robots.iter().zip(&file.trajectories) {
            assert_eq!(r.model, "franka_panda");
            assert_eq!(t.name, format!("{}_goal", r.name));
            assert_eq!(t.poses.len(), 1);
        }
    }

    // two_lean_to_ready: starts at "lean", the hands go where "ready" puts them.
    let text = load::read_text(&out.join("two_lean_to_ready.json")).unwrap();
    let file = load::parse_problem(&text).unwrap();
    assert_eq!(file.robots[0].initial.as_deref(), Some(&LEANING[..]));
    assert_eq!(file.robots[1].initial.as_deref(), Some(&READY[..]));
    let base0 = to_frame(&file.robots[0].base).unwrap();
    assert!((base0.pos - omcbsa_core::nalgebra::Vector3::new(0.6, 0.0, 0.1)).norm() < 1e-12);
    // Facing -x: the base's x axis is the world's -x.
    assert!((base0.rot[(0, 0)] + 1.0).abs() < 1e-12);
    let goal = to_frame(&file.trajectories[0].poses[0]).unwrap();
    let expected = base0.compose(&Fleet::fk(panda, &READY));
    assert!((goal.pos - expected.pos).norm() < 1e-9);
    assert!((goal.rot - expected.rot).norm() < 1e-9);
    // The table segments, and the rod of arm 1 as a capsule across the hand (along the tool
    // frame's x axis after the pitch of pi/2), not arm 0.
    let table = &file.obstacles[0];
    assert_eq!(
        (table.name.as_str(), table.shape),
        ("table_segment_0", ShapeKind::Box)
    );
    assert_eq!(table.half_extents, Some([1.0, 0.2, 0.05]));
    assert_eq!(table.pose.position, [0.0, 0.9, 0.05]);
    assert!(file.robots[0].tool.is_none());
    let rod = file.robots[1].tool.as_ref().unwrap();
    assert_eq!(rod.name, "panda1_rod");
    let [c] = &rod.capsules[..] else {
        panic!("one capsule")
    };
    assert_eq!(c.radius, 0.01);
    for (end, sign) in [(c.a, -1.0), (c.b, 1.0)] {
        let want = [sign * 0.1, 0.0, -0.005];
        assert!(
            end.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12),
            "{end:?}"
        );
    }

    // four: the quad layout's yaws, the table from z and thickness, the bin's floor and walls.
    let text = load::read_text(&out.join("four_ready_to_lean.json")).unwrap();
    let file = load::parse_problem(&text).unwrap();
    let base2 = to_frame(&file.robots[2].base).unwrap();
    assert!((base2.pos - omcbsa_core::nalgebra::Vector3::new(0.5, 0.5, 0.1)).norm() < 1e-12);
    let yaw = base2.rot[(1, 0)].atan2(base2.rot[(0, 0)]);
    assert!(
        (yaw + 3.0 * std::f64::consts::FRAC_PI_4).abs() < 1e-12,
        "{yaw}"
    );
    let named = |n: &str| file.obstacles.iter().find(|o| o.name == n).unwrap();
    assert_eq!(named("table_segment_0").pose.position, [0.0, 1.2, 0.05]);
    assert_eq!(
        named("table_segment_0").half_extents,
        Some([1.0, 0.1, 0.05])
    );
    assert_eq!(named("bin_0_bottom").half_extents, Some([0.15, 0.15, 0.01]));
    let front = named("bin_0_front");
    assert_eq!(front.half_extents, Some([0.15, 0.01, 0.1]));
    assert!((front.pose.position[1] - 0.15).abs() < 1e-12);
    assert!((front.pose.position[2] - 0.11).abs() < 1e-12);

    // Free assignment: no assignment in the index.
    let free = Options {
        assignment: Assignment::Free,
        ..options(&["two"])
    };
    let out_free = dir.path().join("free");
    import(dir.path(), &out_free, &free).unwrap();
    assert!(read_index(&out_free)
        .unwrap()
        .problems
        .iter()
        .all(|e| e.assignment.is_none()));
}

fn error(dir: &Path, envs: &[&str]) -> String {
    import(dir, &dir.join("out"), &options(envs))
        .unwrap_err()
        .to_string()
}

#[test]
fn malformed_or_unsupported_files_are_named_with_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let e = error(dir.path(), &["two"]);
    assert!(e.contains("not a VAMP-MR checkout"), "{e}");

    checkout(dir.path());
    let core = dir.path().join("mr_planner_core");
    let e = error(dir.path(), &["three"]);
    assert!(e.contains("config/srdf/three.srdf: cannot read"), "{e}");

    // A joint value that is not a number.
    let srdf_path = core.join("config/srdf/two.srdf");
    let good = std::fs::read_to_string(&srdf_path).unwrap();
    std::fs::write(
        &srdf_path,
        good.replacen("value=\"-0.5\"", "value=\"-0.5rad\"", 1),
    )
    .unwrap();
    let e = error(dir.path(), &["two"]);
    assert!(
        e.ends_with("two.srdf: group_state \"ready\" (group panda_multi_arm): joint \"panda0_joint2\": value \"-0.5rad\" is not a finite number"),
        "{e}"
    );
    // Two poses whose names make the same file name.
    let pair = [("panda0", LEANING), ("panda1", READY)];
    let twins = format!("{}{}</robot>", state("x y", &pair), state("x_y", &pair));
    std::fs::write(&srdf_path, good.replace("</robot>", &twins)).unwrap();
    let e = error(dir.path(), &["two"]);
    assert!(
        e.contains("two problems would both be written to two_ready_to_x_y.json"),
        "{e}"
    );
    // Not XML.
    std::fs::write(&srdf_path, &good[..good.len() / 2]).unwrap();
    let e = error(dir.path(), &["two"]);
    assert!(e.contains("two.srdf: not XML"), "{e}");
    std::fs::write(&srdf_path, &good).unwrap();

    // A scene builder the importer does not know.
    let factory_path = core.join("src/backends/vamp_env_factory.cpp");
    let odd = FACTORY.replace(
        "add_panda_table_segments(instance, \"two_table\");",
        "add_panda_shelf(instance, \"two_shelf\");",
    );
    std::fs::write(&factory_path, odd).unwrap();
    let e = error(dir.path(), &["two"]);
    assert!(
        e.contains("vamp_env_factory.cpp: function add_environment_obstacles, environment \"two\": add_panda_shelf: a scene builder the importer does not read"),
        "{e}"
    );
    // A table with a row too short.
    let short = FACTORY.replace(
        "{0.0, -0.9, 0.05, 2.0, 0.4, 0.1}",
        "{0.0, -0.9, 0.05, 2.0, 0.4}",
    );
    std::fs::write(&factory_path, short).unwrap();
    let e = error(dir.path(), &["two"]);
    assert!(
        e.contains("function add_panda_table_segments: row 1: expected 6 numbers, found 5"),
        "{e}"
    );
    // Unbalanced source.
    std::fs::write(&factory_path, "namespace vamp_env {\nvoid f() {\n").unwrap();
    let e = error(dir.path(), &["two"]);
    assert!(
        e.contains("vamp_env_factory.cpp: line 2: '{' not closed by '}'"),
        "{e}"
    );
    // An environment the factory does not configure.
    std::fs::write(
        &factory_path,
        FACTORY.replace("name == \"four\"", "name == \"quad\""),
    )
    .unwrap();
    let e = error(dir.path(), &["four"]);
    assert!(
        e.contains("function make_environment_config, environment \"four\": no branch for this environment"),
        "{e}"
    );
    std::fs::write(&factory_path, FACTORY).unwrap();

    // A base-transform file with a misspelt field, or the wrong count.
    let bases = core.join("scripts/plugins/config/panda_two_base_transforms.json");
    std::fs::write(&bases, PAIR_BASES.replacen("\"rpy\"", "\"rpz\"", 1)).unwrap();
    let e = error(dir.path(), &["two"]);
    assert!(
        e.contains("panda_two_base_transforms.json: [0].rpz: unknown field `rpz`"),
        "{e}"
    );
    let e = parse_transforms(Path::new("b.json"), PAIR_BASES, 3)
        .unwrap_err()
        .to_string();
    assert_eq!(e, "b.json: 2 transforms for 3 arms");
    let e = parse_transforms(Path::new("b.json"), "[{\"quaternion\": [0, 0, 0, 2]}]", 1)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("b.json: [0]: quat_xyzw: norm 2"), "{e}");
}
