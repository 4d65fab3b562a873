// Sharded envelope runs: the shard spec is parsed and checked, each draw belongs to one shard, and
// the merge of shards 0..N-1 gives the unsharded run's envelope.json and report byte for byte (non-
// finite metrics, a draw that failed and one that could not be drawn included), with every refusal
// naming the folder.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "swerve/app/envelope.hpp"
#include "swerve/app/shard.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

namespace fs = std::filesystem;

std::string error_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "no error";
}

TEST(Shard, ParsesIOfNAndRefusesWhatIsNot) {
  const Shard shard = parse_shard("2/4");
  EXPECT_EQ(shard.index, 2);
  EXPECT_EQ(shard.count, 4);
  EXPECT_TRUE(shard.owns(6));
  EXPECT_FALSE(shard.owns(7));
  EXPECT_EQ(error_of([] { parse_shard("4/4"); }), "--shard '4/4': I must be in [0, 3]");
  EXPECT_EQ(error_of([] { parse_shard("0/0"); }), "--shard '0/0': N must be >= 1");
  EXPECT_EQ(error_of([] { parse_shard("-1/2"); }), "--shard '-1/2': I must be in [0, 1]");
  EXPECT_EQ(error_of([] { parse_shard("1"); }), "--shard '1': expected I/N, two integers with 0 <= I < N");
  EXPECT_EQ(error_of([] { parse_shard("a/2"); }), "--shard 'a/2': expected I/N, two integers with 0 <= I < N");
  EXPECT_EQ(error_of([] { Shard{3, 2}.validate(); }), "Shard.index = 3: must be in [0, 1] (of 2 shards)");
}

TEST(Shard, EveryItemBelongsToExactlyOneShard) {
  for (int count = 1; count <= 5; ++count) {
    for (int item = 0; item < 23; ++item) {
      int owners = 0;
      for (int index = 0; index < count; ++index) owners += Shard{index, count}.owns(item);
      EXPECT_EQ(owners, 1) << item << " of " << count;
    }
  }
}

// A directory of this test's own (ctest runs tests in parallel processes).
std::string scratch_dir() {
  const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  const fs::path dir = fs::temp_directory_path() / ("swerve_shards_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

EnvelopeOptions options_in(const std::string& out_dir) {
  EnvelopeOptions options;
  options.draws = 7;
  options.seed = 11;
  options.jobs = 2;
  options.out_dir = out_dir;
  options.controller_file = "configs/controllers/default.yaml";
  options.baseline_file = "configs/controllers/kinematic_baseline.yaml";
  return options;
}

// Metrics with every field set, the wear-aware run's made worse on odd draws; draw 3 has an
// infinite wear ratio (a zero baseline) and a NaN jerk; draw 5 failed to load, naming its folder.
DrawResult fake_draw(const EnvelopeOptions& options, int index) {
  const std::vector<ReferenceFamily> families = options.family_list();
  const std::string dir = (fs::path(options.out_dir) / "draws" / std::to_string(index)).string();
  if (index == 6) return undrawn_result(options.seed, index, families, dir, "no vehicle fits");
  DrawResult r;
  r.draw = draw_case(options.seed, index, families);
  r.scenario_file = dir + "/scenario.yaml";
  if (index == 5) {
    r.error = r.scenario_file + ": cannot load";
    r.goals = evaluate_goals(r.wear_mpc, r.baseline);
    return r;
  }
  for (EnvelopeRun* run : {&r.wear_mpc, &r.baseline}) {
    const double scale = run == &r.wear_mpc ? 1.0 + 0.7 * (index % 2) : 1.0;
    RunMetrics& m = run->metrics;
    run->ran = run->completed = true;
    m.steps = 100 + index;
    m.tracking_rmse_m = scale * 0.01 * (index + 1) / 3.0;
    m.tracking_max_m = 0.1 / 7.0;
    m.heading_rmse_rad = scale * 0.003 / 7.0;
    m.heading_max_rad = 0.02;
    m.wear_per_module = {1.0 / 3.0, 2.0 / 3.0, 0.1};
    m.wear_total = index == 3 && run == &r.baseline ? 0.0 : scale * (1.0 + index / 9.0);
    m.wear_imbalance = 1.1;
    m.frictional_energy_J = 2.0 / 9.0;
    m.steering_effort = scale * 0.4 / 3.0;
    m.steering_command_jerk = index == 3 ? std::numeric_limits<double>::quiet_NaN() : 0.7;
    m.solve_time_p99_ms = 1.0 / 3.0;
    m.deadline_misses = index == 4 && run == &r.wear_mpc;
    m.fallbacks = 2;
    run->safe_stops = index == 2 && run == &r.wear_mpc;
  }
  r.goals = evaluate_goals(r.wear_mpc, r.baseline);
  return r;
}

// The run `options` describes, with each draw's folder holding its scenario text.
EnvelopeResult fake_run(const EnvelopeOptions& options) {
  EnvelopeResult result;
  result.options = options;
  for (int i = 0; i < options.draws; ++i) {
    if (!options.shard.owns(i)) continue;
    result.draws.push_back(fake_draw(options, i));
    fs::create_directories(fs::path(options.out_dir) / "draws" / std::to_string(i));
    std::ofstream(fs::path(options.out_dir) / "draws" / std::to_string(i) / "scenario.yaml") << "draw " << i << "\n";
  }
  count_goals(&result);
  return result;
}

TEST(EnvelopeShards, MergeGivesTheUnshardedJsonAndReportByteForByte) {
  const std::string dir = scratch_dir();
  const EnvelopeResult whole = fake_run(options_in(dir + "/whole"));
  std::vector<std::string> shard_dirs;
  for (const int index : {2, 0, 1}) {  // any order
    EnvelopeOptions options = options_in(dir + "/shard" + std::to_string(index));
    options.shard = Shard{index, 3};
    write_envelope_shard(fake_run(options), options.out_dir + "/" + kShardFileName);
    shard_dirs.push_back(options.out_dir);
  }
  const EnvelopeResult merged = merge_envelope_shards(shard_dirs, dir + "/whole_again");
  const EnvelopeResult whole_again = [&] {
    EnvelopeResult r = whole;  // the unsharded run had it been written to whole_again
    for (DrawResult& d : r.draws) {
      const std::string from = dir + "/whole/", to = dir + "/whole_again/";
      d.scenario_file.replace(0, from.size(), to);
      if (d.error.rfind(from, 0) == 0) d.error.replace(0, from.size(), to);
    }
    r.options.out_dir = dir + "/whole_again";
    return r;
  }();
  EXPECT_EQ(envelope_json(merged), envelope_json(whole_again));
  EXPECT_EQ(envelope_report(merged), envelope_report(whole_again));
  EXPECT_EQ(merged.met, whole.met);
  EXPECT_EQ(merged.failed, 2);
  EXPECT_TRUE(std::isinf(merged.draws[3].goals.wear_ratio));
  std::ifstream copied(dir + "/whole_again/draws/4/scenario.yaml");
  std::string line;
  std::getline(copied, line);
  EXPECT_EQ(line, "draw 4");
  fs::remove_all(dir);
}

TEST(EnvelopeShards, MergeRefusesMissingDuplicateAndForeignShardsNamingTheFolder) {
  const std::string dir = scratch_dir();
  const auto shard = [&](int index, int count, std::uint64_t seed, const std::string& name) {
    EnvelopeOptions options = options_in(dir + "/" + name);
    options.draws = 3;  // drawing a case takes a while in a checked build
    options.seed = seed;
    options.shard = Shard{index, count};
    write_envelope_shard(fake_run(options), options.out_dir + "/" + kShardFileName);
    return options.out_dir;
  };
  const std::string a = shard(0, 2, 11, "a"), b = shard(1, 2, 11, "b"), c = shard(1, 2, 12, "c");
  const std::string d = shard(1, 3, 11, "d");
  const std::string out = dir + "/out";
  EXPECT_EQ(error_of([&] { merge_envelope_shards({a}, out); }), "merge: shard 1/2 is missing");
  EXPECT_EQ(error_of([&] { merge_envelope_shards({a, a, b}, out); }),
            "merge: shard 0/2 given twice (" + a + " and " + a + ")");
  EXPECT_NE(error_of([&] { merge_envelope_shards({a, c}, out); }).find("merge: " + c + " is a shard of another envelope run"),
            std::string::npos);
  EXPECT_EQ(error_of([&] { merge_envelope_shards({a, d}, out); }),
            "merge: " + d + " is shard 1/3, but " + a + " is of 2 shards");
  EXPECT_EQ(error_of([&] { merge_envelope_shards({a, dir + "/nowhere"}, out); }).find(dir + "/nowhere/shard.json"),
            0u);
  EXPECT_EQ(error_of([&] { merge_envelope_shards({a, b}, a); }),
            "merge: " + a + " is the output folder itself; merge into another folder");
  EXPECT_EQ(error_of([&] { merge_envelope_shards({a, b}, out); }), "no error");
  // A draw that ran but whose folder the shard lacks: the merge would name files it never copied.
  fs::remove_all(fs::path(b) / "draws" / "1");
  EXPECT_EQ(error_of([&] { merge_envelope_shards({a, b}, out); }),
            b + "/shard.json: draw 1 ran, but " + b + "/draws/1 is missing");
  // A member of the wrong type is named with its file, not thrown as a bare JSON error.
  std::ofstream(fs::path(b) / "shard.json") << "{\"command\": 5, \"format\": 1}";
  EXPECT_EQ(error_of([&] { merge_envelope_shards({a, b}, out); }),
            b + "/shard.json: not the record of an envelope shard (\"command\": \"envelope\", format 1)");
  std::ofstream(fs::path(b) / "shard.json") << "{\"command\": \"envelope\", \"format\": 1, \"shard_index\": \"1\"}";
  EXPECT_EQ(error_of([&] { merge_envelope_shards({a, b}, out); }).rfind(b + "/shard.json: [json.exception.type_error", 0), 0u);
  fs::remove_all(dir);
}

// The merge moves a shard's folder to the output folder where a path starts, not inside another
// path that happens to contain it (once "/backup<shard>/draws/" became "/backup<out>/draws/").
TEST(EnvelopeShards, MergeMovesOnlyPathsThatStartWithTheShardsFolder) {
  const std::string dir = scratch_dir();
  std::vector<std::string> shard_dirs;
  for (const int index : {0, 1}) {
    EnvelopeOptions options = options_in(dir + "/shard" + std::to_string(index));
    options.draws = 2;
    options.shard = Shard{index, 2};
    EnvelopeResult run = fake_run(options);
    if (index == 1) {
      DrawResult& r = run.draws.front();
      r.error = r.scenario_file + ": cannot load (a copy is in /backup" + options.out_dir + "/draws/1)";
    }
    write_envelope_shard(run, options.out_dir + "/" + kShardFileName);
    shard_dirs.push_back(options.out_dir);
  }
  const EnvelopeResult merged = merge_envelope_shards(shard_dirs, dir + "/out");
  EXPECT_EQ(merged.draws[1].error, dir + "/out/draws/1/scenario.yaml: cannot load (a copy is in /backup" + dir +
                                       "/shard1/draws/1)");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace swerve
