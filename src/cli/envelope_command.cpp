// `swerve-mpc envelope --draws N --seed S`: the operating envelope generator (app/envelope.hpp).
// Draws random vehicles, references and conditions, writes each as a scenario, runs the wear-aware
// controller against the kinematic baseline on it, and reports how often the goals hold.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "command_registry.hpp"
#include "swerve/app/envelope.hpp"
#include "swerve/core/error_text.hpp"

namespace swerve::cli {
namespace {

// Options are kept as text and converted here, so that no conversion by the parser can clamp,
// wrap or round a value before it is checked ("-1" for an unsigned seed, "2.5" draws).
struct EnvelopeArguments {
  std::string draws, seed, jobs = "1";
  std::vector<std::string> families;
  std::string out_dir = "out/envelope";
  std::string controller_file = "configs/controllers/default.yaml";
  std::string baseline_file = "configs/controllers/kinematic_baseline.yaml";
  bool wall_clock = false;
  WorkClockRates work_clock;  // per_read_s 0: not given (the envelope's default work clock)
  bool quiet = false;
  std::string shard;  // "I/N"; empty: the whole run
};

template <typename Integer>
std::optional<Integer> integer_value(const std::string& text) {
  Integer value{};
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (text.empty() || error != std::errc() || stop != end) return std::nullopt;
  return value;
}

// An integer option in [lower, upper]; CLI11 puts the option's name in front of the message.
CLI::Validator integer_rule(long long lower, long long upper, const std::string& type_name) {
  return CLI::Validator(
      [lower, upper](std::string& text) -> std::string {
        const std::optional<long long> value = integer_value<long long>(text);
        if (value && *value >= lower && *value <= upper) return "";
        return "'" + printable_value(text) + "': must be an integer in [" + std::to_string(lower) + ", " +
               std::to_string(upper) + "]";
      },
      type_name);
}

const CLI::Validator kSeedRule(
    [](std::string& text) -> std::string {
      if (integer_value<std::uint64_t>(text)) return "";
      return "'" + printable_value(text) + "': must be an integer in [0, " +
             std::to_string(std::numeric_limits<std::uint64_t>::max()) + "]";
    },
    "SEED");

// Each name of --families (CLI11 checks the list's elements one by one).
const CLI::Validator kFamilyRule(
    [](std::string& name) -> std::string {
      if (name.empty())
        return "'': an empty family name (name at least one of: " + reference_family_names() + ")";
      if (reference_family_named(name)) return "";
      return "'" + printable_value(name) + "': unknown family (families: " + reference_family_names() + ")";
    },
    "FAMILY");

// One line per finished draw on a terminal; nothing when stderr is not one (logs stay clean).
EnvelopeCallback progress_line(bool quiet) {
  if (quiet || !isatty(STDERR_FILENO)) return {};
  return [](const DrawResult& r, int done, int total) {
    std::fprintf(stderr, "\r  draw %d/%d done (%s: %s)%s", done, total, to_string(r.draw.family),
                 !r.error.empty() || !r.goals.ran ? "failed"
                 : r.goals.all()                  ? "goals met"
                                                  : "goals not met",
                 done == total ? "\n" : "          ");
    std::fflush(stderr);
  };
}

int run(const EnvelopeArguments& a, bool families_given) {
  EnvelopeOptions options;
  // The validators above have accepted these texts.
  options.draws = static_cast<int>(*integer_value<long long>(a.draws));
  options.seed = *integer_value<std::uint64_t>(a.seed);
  options.jobs = static_cast<int>(*integer_value<long long>(a.jobs));
  if (families_given && a.families.empty()) {
    throw UsageError("--families '': must name at least one family (" + reference_family_names() + ")");
  }
  options.families = a.families;
  options.out_dir = a.out_dir;
  options.controller_file = a.controller_file;
  options.baseline_file = a.baseline_file;
  if (a.wall_clock) {
    options.work_clock = 0.0;
  } else if (a.work_clock.per_read_s > 0.0) {
    options.work_clock = a.work_clock.per_read_s;
  }
  options.work_clock_evaluation = a.work_clock.per_module_evaluation_s;
  try {
    if (!a.shard.empty()) options.shard = parse_shard(a.shard);
    options.validate();
  } catch (const ConfigError& error) {
    throw UsageError(std::string("envelope: ") + error.what());
  }
  const unsigned cores = std::thread::hardware_concurrency();
  if (a.wall_clock && cores > 0 && static_cast<unsigned>(options.jobs) >= cores) {
    // Every core busy with a run leaves none for the operating system: its work then preempts a
    // controller step now and then, and the deadline misses measure that contention, not the controller.
    std::cerr << "envelope: warning: --wall-clock with --jobs " << options.jobs << " on " << cores
              << " cores leaves no core for the operating system; deadline misses will count its preemptions "
                 "(use --jobs "
              << (cores > 1 ? cores - 1 : 1) << " or fewer for a wall-clock measurement)\n";
  }
  const EnvelopeResult result = run_envelope(options, progress_line(a.quiet));
  if (!options.shard.whole()) {
    // A shard's share is no envelope on its own: its record waits for `swerve-mpc merge`.
    const std::string shard_path = options.out_dir + "/" + kShardFileName;
    write_envelope_shard(result, shard_path);
    std::cout << "envelope shard " << options.shard.text() << ": " << result.draws.size() << " of " << options.draws
              << " draws, " << result.met << " meeting every goal\n"
              << "written: " << shard_path << " (swerve-mpc merge <the shards' folders> -o <out>)\n";
    return kExitOk;
  }
  const std::string json_path = options.out_dir + "/envelope.json";
  write_envelope_json(result, json_path);
  std::cout << envelope_report(result);
  std::cout << "written: " << json_path << " and " << result.draws.size() << " scenarios in "
            << options.out_dir << "/draws/\n";
  // Draws that miss their goals or fail to run are the envelope's findings, reported above: the
  // command itself succeeded.
  return kExitOk;
}

}  // namespace

Command make_envelope_command() {
  return {
      "envelope",
      "Operating envelope: random vehicles, references and conditions from a seed, wear-aware MPC against "
      "the "
      "kinematic baseline on each, and how often the goals hold",
      [](CLI::App& app) -> std::function<int()> {
        auto a = std::make_shared<EnvelopeArguments>();
        app.add_option("--draws", a->draws, "Number of random cases, an integer >= 1")
            ->required()
            ->check(integer_rule(1, 1000000, "N"));
        app.add_option("--seed", a->seed, "Seed of the draws, an integer >= 0 (same seed: same draws)")
            ->required()
            ->check(kSeedRule);
        app.add_option("--jobs", a->jobs, "Draws run in parallel threads [1]")
            ->check(integer_rule(1, 1024, "J"));
        CLI::Option* families =
            app.add_option("--families", a->families,
                           "Reference families, comma-separated [all]: " + reference_family_names())
                ->delimiter(',')
                ->check(kFamilyRule);
        app.add_option("-o,--out", a->out_dir, "Output directory [out/envelope]");
        app.add_option("--controller", a->controller_file,
                       "Wear-aware controller file copied into each draw [configs/controllers/default.yaml]");
        app.add_option("--baseline", a->baseline_file,
                       "Baseline controller file copied into each draw "
                       "[configs/controllers/kinematic_baseline.yaml]");
        CLI::Option* wall = app.add_flag("--wall-clock", a->wall_clock,
                                         "Keep deadlines on the wall clock instead of the default work clock "
                                         "(the reference machine's rates)");
        add_work_clock_option(app, &a->work_clock);
        if (CLI::Option* work = app.get_option_no_throw("--work-clock")) wall->excludes(work);
        app.add_flag("-q,--quiet", a->quiet, "No progress line");
        app.add_option("--shard", a->shard,
                       "I/N: run draws whose index is I modulo N and write <out>/shard.json for swerve-mpc merge");
        return [a, families]() { return run(*a, families->count() > 0); };
      }};
}

}  // namespace swerve::cli
