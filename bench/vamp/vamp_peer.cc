// VAMP's side of omcbsa's side-by-side comparison: VAMP's Panda checks on the scene of
// core/benches/scenes/panda_vamp.json (read from the project), timed exactly as
// host/examples/peer_scene.rs times omcbsa's: per case, an untimed pass that counts hits, then
// PASSES passes over all items, each repeated to last about PASS_MS; time per item.
//
// usage: vamp_peer SCENE.json FK_CONFIGS.json [PASSES=21] [PASS_MS=5]
// prints: system case items hits median_ns min_ns max_ns (tab-separated)

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <vamp/collision/factory.hh>
#include <vamp/planning/validate.hh>
#include <vamp/robots/panda.hh>

using json = nlohmann::json;
using Robot = vamp::robots::Panda;
static constexpr std::size_t rake = vamp::FloatVectorWidth;  // 8 with AVX2
using EnvIn = vamp::collision::Environment<float>;
using Env8 = vamp::collision::Environment<vamp::FloatVector<rake>>;
using Array = std::array<float, Robot::dimension>;

template <typename T> inline void keep(T const &v) { asm volatile("" : : "g"(&v) : "memory"); }

static int passes = 21;
static double pass_ms = 5.0;

template <typename T, typename Op>
static void measure(const char *system, const std::string &name, const std::vector<T> &items,
                    double per_item_divisor, Op op)
{
    std::size_t hits = 0;
    for (const auto &x : items) hits += op(x) ? 1 : 0;
    auto pass = [&](std::size_t reps) {
        auto t0 = std::chrono::steady_clock::now();
        std::size_t n = 0;
        for (std::size_t r = 0; r < reps; ++r)
            for (const auto &x : items) { keep(x); n += op(x) ? 1 : 0; }
        keep(n);
        return std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
    };
    double once = std::max(pass(1), 1.0);
    std::size_t reps = std::max<std::size_t>(1, (std::size_t)std::ceil(pass_ms * 1e6 / once));
    std::vector<double> ns;
    for (int p = 0; p < std::max(passes, 1); ++p)
        ns.push_back(pass(reps) / (double(reps) * double(items.size()) * per_item_divisor));
    std::sort(ns.begin(), ns.end());
    std::printf("%s\t%s\t%zu\t%zu\t%.1f\t%.1f\t%.1f\n", system, name.c_str(), items.size(), hits,
                ns[ns.size() / 2], ns.front(), ns.back());
    std::fflush(stdout);
}

static Array config(const json &q)
{
    if (q.size() != Robot::dimension) throw std::runtime_error("configuration of the wrong length");
    Array a;
    for (std::size_t i = 0; i < Robot::dimension; ++i) a[i] = q[i].get<float>();
    return a;
}

// Consecutive groups of `rake` configurations as VAMP's SIMD blocks (a leftover short group is
// dropped).
static std::vector<Robot::ConfigurationBlock<rake>> blocks_of(const std::vector<Array> &qs)
{
    std::vector<Robot::ConfigurationBlock<rake>> blocks(qs.size() / rake);
    for (std::size_t k = 0; k < blocks.size(); ++k)
        for (std::size_t i = 0; i < Robot::dimension; ++i)
        {
            std::array<float, rake> lane;
            for (std::size_t l = 0; l < rake; ++l) lane[l] = qs[k * rake + l][i];
            blocks[k][i] = vamp::FloatVector<rake>(lane);
        }
    return blocks;
}

// The scene's obstacles (the problem format's entries) as VAMP shapes, in the lists VAMP's
// own Python Environment.add_* put them in (z-aligned ones in their fast lists).
static EnvIn environment(const json &obstacles)
{
    EnvIn env;
    for (const auto &o : obstacles)
    {
        const auto shape = o.at("shape").get<std::string>();
        const auto &p = o.at("pose").at("position");
        const auto &q = o.at("pose").at("quat_xyzw");
        Eigen::Vector3f c(p[0].get<float>(), p[1].get<float>(), p[2].get<float>());
        Eigen::Matrix3f r =
            Eigen::Quaternionf(q[3].get<float>(), q[0].get<float>(), q[1].get<float>(), q[2].get<float>())
                .normalized()
                .toRotationMatrix();
        if (shape == "sphere")
            env.spheres.emplace_back(vamp::collision::factory::sphere::eigen(c, o.at("radius").get<float>()));
        else if (shape == "box")
        {
            const auto &h = o.at("half_extents");
            vamp::collision::Cuboid<float> b(
                c[0], c[1], c[2], r(0, 0), r(1, 0), r(2, 0), r(0, 1), r(1, 1), r(2, 1), r(0, 2), r(1, 2), r(2, 2),
                h[0].get<float>(), h[1].get<float>(), h[2].get<float>());
            (b.axis_3_z == 1.F ? env.z_aligned_cuboids : env.cuboids).push_back(b);
        }
        else if (shape == "capsule" or shape == "cylinder")
        {
            Eigen::Vector3f half = r.col(2) * o.at("half_length").get<float>();
            Eigen::Vector3f a = c - half, b = c + half;
            float radius = o.at("radius").get<float>();
            if (shape == "cylinder")
                env.cylinders.push_back(vamp::collision::factory::cylinder::endpoints::eigen(a, b, radius));
            else
            {
                auto cap = vamp::collision::factory::capsule::endpoints::eigen(a, b, radius);
                (cap.xv == 0.F and cap.yv == 0.F ? env.z_aligned_capsules : env.capsules).push_back(cap);
            }
        }
        else
            throw std::runtime_error("unknown obstacle shape " + shape);
    }
    env.sort();
    return env;
}

int main(int argc, char **argv)
{
    if (argc < 3)
    {
        std::fprintf(stderr, "usage: vamp_peer SCENE.json FK_CONFIGS.json [PASSES] [PASS_MS]\n");
        return 2;
    }
    if (argc > 3) passes = std::stoi(argv[3]);
    if (argc > 4) pass_ms = std::stod(argv[4]);
    json scene = json::parse(std::ifstream(argv[1]));
    json fk = json::parse(std::ifstream(argv[2]));
    const EnvIn env_in = environment(scene.at("obstacles"));
    const Env8 env8(env_in);

    if (argc > 5 and std::string(argv[5]) == "--diagnose")
    {
        // Per configuration of the scene's lists that VAMP finds in collision: which spheres
        // meet an obstacle and which self pairs meet (VAMP's fkcc_debug), on standard error.
        for (const char *list : {"free", "random"})
        {
            std::size_t k = 0, self = 0, obstacle = 0, both = 0;
            for (const auto &q : scene.at(list))
            {
                Robot::ConfigurationBlock<rake> b;
                auto a = config(q);
                for (std::size_t i = 0; i < Robot::dimension; ++i) b[i] = vamp::FloatVector<rake>::fill(a[i]);
                auto d = Robot::fkcc_debug<rake>(env8, b);
                std::size_t env_hits = 0;
                for (const auto &s : d.first) env_hits += s.empty() ? 0 : 1;
                if (env_hits or not d.second.empty())
                {
                    std::fprintf(stderr, "%s[%zu]: %zu spheres meet obstacles, %zu self pairs meet:", list, k,
                                 env_hits, d.second.size());
                    for (const auto &[i, j] : d.second) std::fprintf(stderr, " %zu-%zu", i, j);
                    std::fprintf(stderr, "\n");
                    self += d.second.empty() ? 0 : 1;
                    obstacle += env_hits ? 1 : 0;
                    both += (env_hits and not d.second.empty()) ? 1 : 0;
                }
                ++k;
            }
            std::fprintf(stderr, "%s: %zu configurations with an obstacle contact, %zu with a self contact, %zu both\n",
                         list, obstacle, self, both);
        }
        return 0;
    }
    std::printf("system\tcase\titems\thits\tmedian_ns\tmin_ns\tmax_ns\n");
    for (const char *list : {"random", "free"})
    {
        // The free list: only the configurations VAMP finds free, so that its rows time the
        // full check (omcbsa's free list was chosen by omcbsa's geometry, and VAMP's checks
        // self pairs that the Panda's SRDF disables).
        const bool only_free = std::string(list) == "free";
        std::vector<Array> qs;
        for (const auto &q : scene.at(list))
        {
            Robot::Configuration c(config(q));
            if (not only_free or vamp::planning::validate_motion<Robot, rake, 1>(c, c, env8))
                qs.push_back(config(q));
        }

        // One configuration per call as VAMP's Python `validate` does it: the configuration in
        // all 8 lanes (validate_motion from q to q at resolution 1). A rake of 1 (fkcc<1>)
        // does not compile at this VAMP commit: its point-cloud check takes 8-lane vectors only.
        std::vector<Robot::Configuration> cs;
        for (const auto &q : qs) cs.emplace_back(q);
        measure("vamp", std::string("check_") + list, cs, 1.0, [&](const auto &c) {
            return not vamp::planning::validate_motion<Robot, rake, 1>(c, c, env8);
        });

        // 8 configurations per call (the SIMD rake): `hits` counts the calls with any
        // configuration in collision (fkcc answers for all 8 at once); time per configuration.
        auto blocks = blocks_of(qs);
        measure("vamp", std::string("batch8_") + list, blocks, double(rake),
                [&](const auto &b) { return not Robot::fkcc<rake>(env8, b); });
    }

    for (const auto &set : scene.at("motions"))
    {
        std::vector<std::array<Robot::Configuration, 2>> ms;
        // Only the motions VAMP finds valid (as for the free list): its full check.
        for (const auto &m : set.at("pairs"))
        {
            std::array<Robot::Configuration, 2> pair{Robot::Configuration(config(m[0])), Robot::Configuration(config(m[1]))};
            if (vamp::planning::validate_motion<Robot, rake, Robot::resolution>(pair[0], pair[1], env8))
                ms.push_back(pair);
        }
        char name[64];
        std::snprintf(name, sizeof name, "motion_%g", set.at("length_rad").get<double>());
        measure("vamp", name, ms, 1.0, [&](const auto &m) {
            return not vamp::planning::validate_motion<Robot, rake, Robot::resolution>(m[0], m[1], env8);
        });
    }

    // FK: the end effector (panda_grasptarget; omcbsa's tool frame is panda_hand_tcp) and all
    // collision spheres, 8 configurations per call.
    std::vector<Array> fq;
    for (const auto &q : fk.at("models").at("franka_panda").at("configurations")) fq.push_back(config(q));
    measure("vamp", "fk_franka_panda", fq, 1.0, [&](const auto &q) {
        auto tf = Robot::eefk(q);
        keep(tf);
        return false;
    });
    auto fblocks = blocks_of(fq);
    measure("vamp", "spherefk8_franka_panda", fblocks, double(rake), [&](const auto &b) {
        Robot::Spheres<rake> out;
        Robot::sphere_fk<rake>(b, out);
        keep(out);
        return false;
    });
    return 0;
}
