// Orocos KDL's forward kinematics on the configurations omcbsa's FK rows time, as a peer in
// the same run (docs/bench/collision.md). Per model in FK_CONFIGS.json, from its folder
// ROBOTS/<model>: KDL's chain from the model's base link to its tool frame, parsed from the model's URDF by kdl_parser; each
// configuration's tool pose checked against omcbsa's, then timed exactly as
// host/examples/peer_scene.rs times omcbsa's FK (an untimed pass, then PASSES passes over all
// configurations, each repeated to last about PASS_MS; time per configuration).
//
// usage: kdl_fk FK_CONFIGS.json PASSES PASS_MS ROBOTS
// FK_CONFIGS.json: written by `peer_scene fk-configs`. Prints tab-separated rows
// `kdl fk_<model> items 0 median_ns min_ns max_ns`; exits 1 when KDL's pose of a configuration
// differs from omcbsa's by more than 1e-9 (a different chain, not a slower one).

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/tree.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <nlohmann/json.hpp>

using json = nlohmann::json;

template <typename T> inline void keep(T const &v) { asm volatile("" : : "g"(&v) : "memory"); }

static json read_json(const std::string &path)
{
    std::ifstream in(path);
    if (not in) throw std::runtime_error(path + ": cannot be read");
    try
    {
        return json::parse(in);
    }
    catch (const json::exception &e)
    {
        throw std::runtime_error(path + ": " + e.what());
    }
}

// Time per configuration of `fk` over `qs`: median, least and most over `passes` passes.
template <typename Fk>
static std::array<double, 3> measure(const std::vector<KDL::JntArray> &qs, int passes, double pass_ms, Fk fk)
{
    for (const auto &q : qs) fk(q);
    auto pass = [&](std::size_t reps) {
        auto t0 = std::chrono::steady_clock::now();
        for (std::size_t r = 0; r < reps; ++r)
            for (const auto &q : qs) { keep(q); fk(q); }
        return std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
    };
    double once = std::max(pass(1), 1.0);
    std::size_t reps = std::max<std::size_t>(1, (std::size_t)std::ceil(pass_ms * 1e6 / once));
    std::vector<double> ns;
    for (int p = 0; p < std::max(passes, 1); ++p) ns.push_back(pass(reps) / (double(reps) * double(qs.size())));
    std::sort(ns.begin(), ns.end());
    return {ns[ns.size() / 2], ns.front(), ns.back()};
}

static int run(int argc, char **argv)
{
    if (argc != 5)
    {
        std::fprintf(stderr, "usage: kdl_fk FK_CONFIGS.json PASSES PASS_MS ROBOTS\n");
        return 2;
    }
    const json configs = read_json(argv[1]).at("models");
    const int passes = std::stoi(argv[2]);
    const double pass_ms = std::stod(argv[3]);
    std::printf("system\tcase\titems\thits\tmedian_ns\tmin_ns\tmax_ns\n");
    for (const auto &[name, set] : configs.items())
    {
        const std::string folder = std::string(argv[4]) + "/" + name;
        const json model = read_json(folder + "/model.json");
        KDL::Tree tree;
        const auto urdf = folder + "/" + model.at("urdf").get<std::string>();
        if (not kdl_parser::treeFromFile(urdf, tree)) throw std::runtime_error(urdf + ": kdl_parser cannot read it");
        KDL::Chain chain;
        const auto base = model.at("base_link").get<std::string>(), tool = model.at("tool_frame").get<std::string>();
        if (not tree.getChain(base, tool, chain))
            throw std::runtime_error(urdf + ": no chain from " + base + " to " + tool);
        KDL::ChainFkSolverPos_recursive solver(chain);

        std::vector<KDL::JntArray> qs;
        for (const auto &q : set.at("configurations"))
        {
            if (q.size() != chain.getNrOfJoints())
                throw std::runtime_error(name + ": a configuration of " + std::to_string(q.size()) + " values, the chain has " +
                                         std::to_string(chain.getNrOfJoints()) + " joints");
            KDL::JntArray j(chain.getNrOfJoints());
            for (unsigned i = 0; i < j.rows(); ++i) j(i) = q[i].get<double>();
            qs.push_back(j);
        }
        // The same chain: every tool pose within 1e-9 of omcbsa's (m, and rotation entries).
        double worst = 0;
        for (std::size_t k = 0; k < qs.size(); ++k)
        {
            KDL::Frame f;
            solver.JntToCart(qs[k], f);
            const auto &t = set.at("tool")[k];
            for (int i = 0; i < 3; ++i)
            {
                worst = std::max(worst, std::fabs(f.p(i) - t.at("position")[i].get<double>()));
                for (int c = 0; c < 3; ++c)
                    worst = std::max(worst, std::fabs(f.M(i, c) - t.at("rotation_col_major")[3 * c + i].get<double>()));
            }
        }
        std::fprintf(stderr, "kdl %s: %s -> %s, %u joints, %u segments; largest difference from omcbsa's tool poses %.3g\n",
                     name.c_str(), base.c_str(), tool.c_str(), chain.getNrOfJoints(), chain.getNrOfSegments(), worst);
        if (not(worst <= 1e-9))
        {
            std::fprintf(stderr, "kdl %s: KDL's chain does not give omcbsa's tool poses\n", name.c_str());
            return 1;
        }
        KDL::Frame out;
        const auto t = measure(qs, passes, pass_ms, [&](const KDL::JntArray &q) {
            solver.JntToCart(q, out);
            keep(out);
        });
        std::printf("kdl\tfk_%s\t%zu\t0\t%.1f\t%.1f\t%.1f\n", name.c_str(), qs.size(), t[0], t[1], t[2]);
        std::fflush(stdout);
    }
    return 0;
}

int main(int argc, char **argv)
{
    try
    {
        return run(argc, argv);
    }
    catch (const std::exception &e)
    {
        std::fprintf(stderr, "kdl_fk: %s\n", e.what());
        return 1;
    }
}
