// Reference timings of Pinocchio (C++, from the `pin` wheel) on urdf/jk5.urdf,
// for the ratios in BENCHMARKS.md. Build with bench/reference/build_pinocchio_bench.sh.
//
// Methodology (the Rust side uses the same one):
//   * S = 1000 random states, generated before timing from a fixed seed:
//     q ~ U(-3.14, 3.14) (joint range), v ~ U(-pi, pi) (velocity limit),
//     a ~ U(-10, 10) rad/s^2, tau ~ U(-100, 100) N m (effort limit).
//   * one batch = one call per state, S calls in a row, timed with steady_clock;
//     ns per call = batch time / S. 20 warm-up batches, then B >= 50 timed batches
//     (default 200); the figure is the median over the batches.
//   * rnea(q, v, a); crba(q) (Pinocchio fills the upper triangle of M only);
//     aba(q, v, tau); frame_jacobian = computeFrameJacobian(q, tip, LOCAL_WORLD_ALIGNED),
//     which includes the forward kinematics it needs.
//   * Model/Data and the Jacobian are allocated once, before timing.
// Prints ONE JSON line on stdout; a checksum of all results goes to stderr so no
// call can be optimised away.
//
// Usage: pinocchio_bench URDF [--batches B] [--states S] [--seed N] [--tip PARENT X Y Z]
//   --tip: a URDF without a 'tip' frame (a stock arm; a robot file's tip_frame given as
//   {parent: PARENT, xyz: [X, Y, Z]}): add frame 'tip' on PARENT's frame at (X, Y, Z) m.
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/parsers/urdf.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <random>
#include <string>
#include <vector>

namespace {

struct State {
  Eigen::VectorXd q, v, a, tau;
};

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr,
               "pinocchio_bench: %s\nusage: pinocchio_bench URDF [--batches B>=50] "
               "[--states S>=1] [--seed N]\n",
               why.c_str());
  std::exit(2);
}

long parse_positive(const char* flag, const char* text) {
  char* end = nullptr;
  long value = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || value < 1)
    usage(std::string(flag) + " needs a positive integer, got '" + text + "'");
  return value;
}

template <class F>
double median_ns_per_call(F&& one_batch, int batches, int states) {
  using clock = std::chrono::steady_clock;
  for (int w = 0; w < 20; ++w) one_batch();
  std::vector<double> ns(batches);
  for (int b = 0; b < batches; ++b) {
    auto t0 = clock::now();
    one_batch();
    auto t1 = clock::now();
    ns[b] = std::chrono::duration<double, std::nano>(t1 - t0).count() / states;
  }
  std::nth_element(ns.begin(), ns.begin() + batches / 2, ns.end());
  double upper = ns[batches / 2];
  if (batches % 2 == 1) return upper;
  double lower = *std::max_element(ns.begin(), ns.begin() + batches / 2);
  return 0.5 * (lower + upper);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) usage("missing the URDF path (e.g. urdf/jk5.urdf)");
  std::string urdf = argv[1];
  int batches = 200, states = 1000;
  unsigned long seed = 20260522;
  std::string tip_parent;
  double tip_xyz[3] = {0.0, 0.0, 0.0};
  for (int i = 2; i < argc; ++i) {
    std::string flag = argv[i];
    if (i + 1 >= argc) usage(flag + " needs a value");
    if (flag == "--tip") {
      if (i + 4 >= argc) usage("--tip needs PARENT X Y Z (the robot file's tip_frame)");
      tip_parent = argv[++i];
      for (int k = 0; k < 3; ++k) {
        char* end = nullptr;
        tip_xyz[k] = std::strtod(argv[++i], &end);
        if (end == argv[i] || *end != '\0') usage(std::string("--tip: '") + argv[i] + "' is not a number (m)");
      }
    } else if (flag == "--batches")
      batches = static_cast<int>(parse_positive("--batches", argv[++i]));
    else if (flag == "--states")
      states = static_cast<int>(parse_positive("--states", argv[++i]));
    else if (flag == "--seed")
      seed = static_cast<unsigned long>(parse_positive("--seed", argv[++i]));
    else
      usage("unknown argument '" + flag + "'");
  }
  if (batches < 50) usage("--batches must be at least 50 for a meaningful median");

  pinocchio::Model model;
  try {
    pinocchio::urdf::buildModel(urdf, model);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pinocchio_bench: cannot load URDF '%s': %s\n", urdf.c_str(), e.what());
    return 1;
  }
  if (!tip_parent.empty()) {
    if (model.existFrame("tip")) {
      std::fprintf(stderr, "pinocchio_bench: URDF '%s' has a frame 'tip' already; drop --tip\n", urdf.c_str());
      return 1;
    }
    if (!model.existFrame(tip_parent)) {
      std::fprintf(stderr, "pinocchio_bench: --tip: URDF '%s' has no frame '%s'\n", urdf.c_str(), tip_parent.c_str());
      return 1;
    }
    const pinocchio::FrameIndex p = model.getFrameId(tip_parent);
    const pinocchio::Frame& pf = model.frames[p];
    pinocchio::SE3 offset(Eigen::Matrix3d::Identity(), Eigen::Vector3d(tip_xyz[0], tip_xyz[1], tip_xyz[2]));
    model.addFrame(pinocchio::Frame("tip", pf.parentJoint, p, pf.placement * offset, pinocchio::OP_FRAME));
  }
  if (!model.existFrame("tip")) {
    std::fprintf(stderr, "pinocchio_bench: URDF '%s' has no frame 'tip' (add one with --tip PARENT X Y Z)\n", urdf.c_str());
    return 1;
  }
  const pinocchio::FrameIndex tip = model.getFrameId("tip");
  pinocchio::Data data(model);
  const int nv = model.nv;

  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uq(-3.14, 3.14), uv(-M_PI, M_PI), ua(-10.0, 10.0),
      ut(-100.0, 100.0);
  std::vector<State> xs(states);
  for (auto& s : xs) {
    s.q.resize(model.nq);
    s.v.resize(nv);
    s.a.resize(nv);
    s.tau.resize(nv);
    for (int k = 0; k < model.nq; ++k) s.q[k] = uq(rng);
    for (int k = 0; k < nv; ++k) s.v[k] = uv(rng);
    for (int k = 0; k < nv; ++k) s.a[k] = ua(rng);
    for (int k = 0; k < nv; ++k) s.tau[k] = ut(rng);
  }
  pinocchio::Data::Matrix6x J = pinocchio::Data::Matrix6x::Zero(6, nv);
  double sink = 0.0;

  const double rnea_ns = median_ns_per_call(
      [&] {
        for (const auto& s : xs) sink += pinocchio::rnea(model, data, s.q, s.v, s.a)[0];
      },
      batches, states);
  const double crba_ns = median_ns_per_call(
      [&] {
        for (const auto& s : xs) sink += pinocchio::crba(model, data, s.q)(0, nv - 1);
      },
      batches, states);
  const double aba_ns = median_ns_per_call(
      [&] {
        for (const auto& s : xs) sink += pinocchio::aba(model, data, s.q, s.v, s.tau)[nv - 1];
      },
      batches, states);
  const double jac_ns = median_ns_per_call(
      [&] {
        for (const auto& s : xs) {
          pinocchio::computeFrameJacobian(model, data, s.q, tip, pinocchio::LOCAL_WORLD_ALIGNED, J);
          sink += J(2, 0);
        }
      },
      batches, states);

  std::fprintf(stderr, "pinocchio_bench: checksum %.17g (nv=%d, %d states, %d batches)\n", sink,
               nv, states, batches);
  std::printf(
      "{\"rnea_ns\":%.1f,\"crba_ns\":%.1f,\"aba_ns\":%.1f,\"frame_jacobian_ns\":%.1f}\n",
      rnea_ns, crba_ns, aba_ns, jac_ns);
  return 0;
}
