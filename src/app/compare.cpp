// `peristat compare A.h5 B.h5 [--step K] [--tol T] [--json]`: the displacement difference
// of two results of the same discretisation, B being the reference (io/compare.hpp
// computes it; this file picks the steps and formats the output).
#include "io/compare.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <utility>

#include <nlohmann/json.hpp>

#include "app/commands.hpp"
#include "core/error.hpp"
#include "core/number_text.hpp"
#include "io/results.hpp"

namespace peristat {
namespace {

/// Load factors closer than this are the same load (they are sums of equal increments).
constexpr double k_same_load = 1e-9;

ResultsReader open_reader(const std::string& path) {
  try {
    return ResultsReader(path);
  } catch (const InputError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());  // a missing or foreign file is the user's input
  }
}

int last_step(const ResultsReader& reader, const std::string& path) {
  if (reader.steps().empty()) throw InputError(path + ": the file holds no converged step");
  return reader.steps().back();
}

void require_step(const ResultsReader& reader, const std::string& path, int step) {
  const auto& steps = reader.steps();
  if (steps.empty()) throw InputError(path + ": the file holds no converged step");
  if (!std::binary_search(steps.begin(), steps.end(), step)) {
    throw InputError(path + ": --step " + std::to_string(step) + " is not in the file (steps " +
                     std::to_string(steps.front()) + " to " + std::to_string(steps.back()) + ")");
  }
}

/// The four measures as keys of `out`.
void add_measures(nlohmann::ordered_json& out, const DifferenceMeasures& m) {
  out["relative_l2"] = m.relative_l2;
  out["max_abs"] = m.max_abs;
  out["max_relative"] = m.max_relative;
  out["absolute"] = m.absolute;
}

/// Pretty-printed; NaN and infinities become null, bytes that are not UTF-8 (in a file
/// name, say) U+FFFD.
std::string to_json(const CompareArguments& args, int step_a, int step_b, double lambda_a, double lambda_b,
                    const Comparison& c, std::optional<bool> within) {
  nlohmann::ordered_json out = {{"a", args.a},
                                {"b", args.b},
                                {"step_a", step_a},
                                {"step_b", step_b},
                                {"load_factor", lambda_b},
                                {"load_factor_a", lambda_a},
                                {"load_factor_b", lambda_b},
                                {"particles", c.all.particles},
                                {"held_left_out", c.held_left_out}};
  add_measures(out, c.all);
  nlohmann::ordered_json& bodies = out["bodies"] = nlohmann::ordered_json::object();
  for (const BodyDifference& body : c.bodies) {
    nlohmann::ordered_json entry = {{"index", body.index}, {"particles", body.measures.particles}};
    add_measures(entry, body.measures);
    bodies[body.name] = std::move(entry);
  }
  out["tol"] = args.tol ? nlohmann::ordered_json(*args.tol) : nlohmann::ordered_json(nullptr);
  out["within_tol"] = within ? nlohmann::ordered_json(*within) : nlohmann::ordered_json(nullptr);
  return out.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

void print_measures(const std::string& label, int width, const DifferenceMeasures& m) {
  if (m.absolute) {
    std::printf("%-*s  absolute L2 %.4e m   max |du| %.3e m   (u_B is 0 here: no relative measure)\n", width,
                label.c_str(), m.relative_l2, m.max_abs);
  } else {
    std::printf("%-*s  relative L2 %.4e   max |du| %.3e m   max |du| / max |u_B| %.3e\n", width,
                label.c_str(), m.relative_l2, m.max_abs, m.max_relative);
  }
}

void print_text(const CompareArguments& args, int step_a, int step_b, double lambda_a, double lambda_b,
                const Comparison& c) {
  std::printf(
      "compare %s (step %d, load factor %s) against %s (step %d, load factor %s): %d real particles\n",
      args.a.c_str(), step_a, shortest_decimal(lambda_a).c_str(), args.b.c_str(), step_b,
      shortest_decimal(lambda_b).c_str(), c.all.particles);
  if (c.held_left_out > 0)
    std::printf(
        "  %ld more held as fragments in either file are left out: where a fragment is held is not "
        "determined by the equations\n",
        static_cast<long>(c.held_left_out));
  int width = 3;  // "all"
  for (const BodyDifference& body : c.bodies) width = std::max(width, static_cast<int>(5 + body.name.size()));
  print_measures("all", width, c.all);
  for (const BodyDifference& body : c.bodies) print_measures("body " + body.name, width, body.measures);
}

}  // namespace

int compare_command(const CompareArguments& args) {
  if (args.tol && !(*args.tol > 0.0 && std::isfinite(*args.tol))) {
    throw InputError("--tol: expected a positive number, got " + shortest_decimal(*args.tol));
  }
  const ResultsReader a = open_reader(args.a);
  const ResultsReader b = open_reader(args.b);
  require_same_particles(a, args.a, b, args.b);  // before the steps: a hard incompatibility

  int step_a = 0, step_b = 0;
  if (args.step) {
    require_step(a, args.a, *args.step);
    require_step(b, args.b, *args.step);
    step_a = step_b = *args.step;
  } else {
    step_a = last_step(a, args.a);
    step_b = last_step(b, args.b);
  }
  const double lambda_a = a.load_factor(step_a);
  const double lambda_b = b.load_factor(step_b);
  if (!(std::abs(lambda_a - lambda_b) <= k_same_load)) {
    if (!args.step) {
      throw InputError(args.a + " ends at load factor " + shortest_decimal(lambda_a) + ", " + args.b +
                       " at " + shortest_decimal(lambda_b) + ": choose --step K");
    }
    std::fprintf(stderr,
                 "peristat: warning: step %d is at load factor %s in %s and %s in %s; compared anyway\n",
                 *args.step, shortest_decimal(lambda_a).c_str(), args.a.c_str(),
                 shortest_decimal(lambda_b).c_str(), args.b.c_str());
  }

  const Comparison c = compare_results(a, args.a, step_a, b, args.b, step_b);
  std::optional<bool> within;
  if (args.tol) within = c.all.relative_l2 <= *args.tol;  // false for NaN

  if (args.json) {
    std::printf("%s\n", to_json(args, step_a, step_b, lambda_a, lambda_b, c, within).c_str());
  } else {
    print_text(args, step_a, step_b, lambda_a, lambda_b, c);
  }
  if (!within) return exit_success;
  const char* measure = c.all.absolute ? "absolute L2" : "relative L2";
  // With --json, stdout holds the JSON object alone: the verdict goes to stderr.
  std::FILE* verdict = args.json ? stderr : stdout;
  if (*within) {
    std::fprintf(verdict, "%s %.4e is within --tol %s\n", measure, c.all.relative_l2,
                 shortest_decimal(*args.tol).c_str());
    return exit_success;
  }
  std::fprintf(verdict, "%s %.4e exceeds --tol %s\n", measure, c.all.relative_l2,
               shortest_decimal(*args.tol).c_str());
  return exit_tolerance_exceeded;
}

}  // namespace peristat
