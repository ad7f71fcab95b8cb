// The host pipeline on damaged logs: a short simulated drive, mutated line by line (lines
// dropped, repeated, swapped; numbers replaced by 0, -1, huge, NaN, infinite or the integer
// limits; the file cut short; bytes changed; garbage lines), and the three impossible logs of
// docs/odolog.md (an encoder jump of 10^6 ticks, increments at the integer limits, scans
// without a usable beam). Every mutant goes through the reader and replay, one in four
// through diagnose too, and must keep pipeline_check.hpp's rules: refused with an error that
// names the file, or answered with finite numbers and a verdict. Deterministic (one seed).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "pipeline_check.hpp"
#include "simulated_log.hpp"

using namespace odoerr::sim;

namespace {

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string l;
  while (std::getline(in, l)) out.push_back(l);
  return out;
}

std::string joinLines(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines) out += l + "\n";
  return out;
}

std::vector<std::string> words(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream in(line);
  std::string w;
  while (in >> w) out.push_back(w);
  return out;
}

std::string unwords(const std::vector<std::string>& w) {
  std::string out;
  for (std::size_t i = 0; i < w.size(); ++i) out += (i ? " " : "") + w[i];
  return out;
}

// The first line at or after `from` whose first word is `kind` (the last line if none).
std::size_t lineOf(const std::vector<std::string>& lines, const std::string& kind, std::size_t from) {
  for (std::size_t i = from; i < lines.size(); ++i)
    if (lines[i].rfind(kind + " ", 0) == 0) return i;
  return lines.size() - 1;
}

// One random damage to the lines; what was done, for the failure message.
std::string mutate(std::vector<std::string>* lines, std::mt19937_64* rng) {
  static const char* kValues[] = {"0", "-1", "1e300", "-1e300", "nan", "inf", "-inf", "9223372036854775807",
                                  "-9223372036854775808", "18446744073709551616", "1e-320", "0x10", "", "+"};
  auto pick = [&](std::size_t n) { return std::size_t((*rng)() % std::max<std::size_t>(n, 1)); };
  const std::size_t i = pick(lines->size());
  std::ostringstream what;
  switch ((*rng)() % 7) {
    case 0:
      what << "line " << i + 1 << " dropped";
      lines->erase(lines->begin() + std::ptrdiff_t(i));
      break;
    case 1:
      what << "line " << i + 1 << " repeated";
      lines->insert(lines->begin() + std::ptrdiff_t(i), (*lines)[i]);
      break;
    case 2:
      if (i + 1 < lines->size()) std::swap((*lines)[i], (*lines)[i + 1]);
      what << "lines " << i + 1 << " and " << i + 2 << " swapped";
      break;
    case 3: {
      std::vector<std::string> w = words((*lines)[i]);
      if (w.size() > 1) {
        const std::size_t k = 1 + pick(w.size() - 1);
        w[k] = kValues[pick(sizeof kValues / sizeof kValues[0])];
        what << "line " << i + 1 << " word " << k + 1 << " -> '" << w[k] << "'";
        (*lines)[i] = unwords(w);
      }
      break;
    }
    case 4: {
      std::string& l = (*lines)[i];
      l = l.substr(0, pick(l.size() + 1));
      lines->resize(i + 1);
      what << "cut at line " << i + 1;
      break;
    }
    case 5: {
      std::string& l = (*lines)[i];
      if (!l.empty()) l[pick(l.size())] = char(32 + pick(95));
      what << "a byte of line " << i + 1 << " changed";
      break;
    }
    default:
      lines->insert(lines->begin() + std::ptrdiff_t(i), "enc 1e9 1 2 3 scan");
      what << "garbage before line " << i + 1;
  }
  return what.str();
}

}  // namespace

TEST(PipelineMutations, EveryDamagedLogIsRefusedOrAnsweredByTheRules) {
  const std::vector<std::string> seed = splitLines(test::simulatedLog(31, 400));
  const std::string work = test::tempDir("pipeline-mutations");
  std::mt19937_64 rng(20261128);
  int count[5] = {0, 0, 0, 0, 0};
  for (int k = 0; k < 160; ++k) {
    std::vector<std::string> lines = seed;
    std::string what;
    const int n = 1 + int(rng() % 3);
    for (int m = 0; m < n && !lines.empty(); ++m) what += (m ? "; " : "") + mutate(&lines, &rng);
    test::Reached at;
    const std::string why = test::checkPipeline(joinLines(lines), "mutant.odolog", work, k % 4 == 0, &at);
    EXPECT_EQ(why, "") << "mutant " << k << " (" << what << ")";
    ++count[int(at)];
  }
  // The damage reaches every stage: the reader refuses some, replay and diagnose answer others.
  EXPECT_GE(count[int(test::Reached::kReaderRefused)], 20);
  EXPECT_GE(count[int(test::Reached::kReplayed)], 20);
  EXPECT_GE(count[int(test::Reached::kDiagnosed)], 10);
  std::printf("mutants: %d refused by the reader, %d by replay, %d replayed (diagnose not run), %d refused by "
              "diagnose, %d diagnosed\n", count[0], count[1], count[2], count[3], count[4]);
}

TEST(PipelineMutations, TheRulesCatchWhatTheyAreFor) {
  nlohmann::ordered_json j = {{"a", 1.0}, {"b", {{"c", {0.5, std::nan("")}}}}};
  EXPECT_EQ(test::firstNonFinite(j), "/b/c/1");
  j["b"]["c"][1] = 2.0;
  EXPECT_EQ(test::firstNonFinite(j), "");
  j["d"] = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(test::firstNonFinite(j), "/d");
  // A reader's error must start with the file's name.
  test::Reached at;
  EXPECT_EQ(test::checkPipeline("odolog 1\nbogus\n", "x.odolog", test::tempDir("pipeline-rules"), false, &at), "");
  EXPECT_EQ(at, test::Reached::kReaderRefused);
}

TEST(PipelineMutations, TheImpossibleLogsKeepTheRules) {
  const std::vector<std::string> seed = splitLines(test::simulatedLog(32, 400));
  const std::string work = test::tempDir("pipeline-impossible");
  // An encoder jump of 10^6 ticks half-way.
  std::vector<std::string> jump = seed;
  const std::size_t e = lineOf(jump, "enc", jump.size() / 2);
  std::vector<std::string> w = words(jump[e]);
  ASSERT_GE(w.size(), 4u);
  w[2] = std::to_string(std::stoll(w[2]) + 1000000);
  jump[e] = unwords(w);
  test::Reached at;
  EXPECT_EQ(test::checkPipeline(joinLines(jump), "jump.odolog", work, true, &at), "");
  EXPECT_EQ(at, test::Reached::kDiagnosed) << "the jump is rejected and counted, the rest diagnosed";
  // Increments at the integer limits.
  std::vector<std::string> limits = seed;
  w = words(limits[e]);
  w[2] = "9223372036854775807";
  w[3] = "-9223372036854775808";
  limits[e] = unwords(w);
  EXPECT_EQ(test::checkPipeline(joinLines(limits), "limits.odolog", work, true), "");
  // No usable beam: every range beyond the laser's reach.
  std::vector<std::string> blind = seed;
  for (std::string& l : blind) {
    if (l.rfind("scan ", 0) != 0) continue;
    std::vector<std::string> s = words(l);
    for (std::size_t k = 2; k < s.size(); ++k) s[k] = "0";
    l = unwords(s);
  }
  EXPECT_EQ(test::checkPipeline(joinLines(blind), "blind.odolog", work, true), "");
}

TEST(PipelineMutations, AMapTooLargeForTheResidualGridWidensItsCells) {
  // A 56 km diagonal wall 70 m from the room: at the asked 0.25 m the grid of residuals would
  // have 2.6 x 10^10 cells and the wall 113,000 bins; the cells double until the grid holds
  // at most 2^20, the wall's bins lengthen to 4,096, and the JSON says so. A wall whose box
  // a double cannot hold (the fuzzer's 1e308) gives no grid, and the rules still hold.
  std::vector<std::string> lines = splitLines(test::simulatedLog(33, 300));
  const std::size_t at = lineOf(lines, "wall", 0);
  lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(at), "wall -20000 -20100 20000 19900");
  Odolog log;
  std::string error;
  ASSERT_TRUE(parseOdolog(joinLines(lines), "wide.odolog", &log, &error)) << error;
  DiagnoseOptions d;
  d.threads = 1;
  nlohmann::ordered_json out;
  ASSERT_TRUE(diagnoseOdolog(log, d, &out, &error)) << error;
  const auto& m = out["map_misfit"];
  EXPECT_EQ(m["cell_asked_m"].get<double>(), 0.25);
  EXPECT_EQ(m["cell_m"].get<double>(), 64.0);  // 0.25 x 2^8: 626^2 = 0.39 M cells; at 32 m, 1.56 M
  EXPECT_LE(m["grid"]["nx"].get<double>() * m["grid"]["ny"].get<double>(), 1048576.0);
  EXPECT_NE(m["grid_note"].get<std::string>().find("cells of 64 m instead of 0.25"), std::string::npos)
      << m["grid_note"];
  EXPECT_EQ(m["walls"][0]["bins"].size(), 4096u);
  EXPECT_NEAR(m["walls"][0]["bin_m"].get<double>(), 40000 * std::sqrt(2.0) / 4096, 1e-9);
  EXPECT_EQ(m["walls"][1]["bin_m"].get<double>(), 0.5);
  EXPECT_EQ(test::firstNonFinite(out), "");

  lines[at] = "wall -1e308 -100 1e308 -99";
  const std::string work = test::tempDir("pipeline-wide");
  test::Reached reached;
  EXPECT_EQ(test::checkPipeline(joinLines(lines), "huge.odolog", work, true, &reached), "");
  ASSERT_TRUE(parseOdolog(joinLines(lines), "huge.odolog", &log, &error)) << error;
  nlohmann::ordered_json huge;
  ASSERT_TRUE(diagnoseOdolog(log, d, &huge, &error)) << error;
  EXPECT_NE(huge["map_misfit"]["grid_note"].get<std::string>().find("no grid"), std::string::npos);
  EXPECT_EQ(huge["map_misfit"]["grid"]["nx"], 0);
}

TEST(PipelineMutations, AScanBeforeTheFirstEncoderRecordIsCountedLateNotFused) {
  // The fuzzer's input: the log's only scan stamped before its first encoder record. The
  // filter starts at the first encoder record, so the scan is dropped and counted late: one
  // late, none fused, and the two add up to the log's scans.
  std::vector<std::string> lines = splitLines(test::simulatedLog(34, 40));
  const std::size_t first_scan = lineOf(lines, "scan", 0);
  ASSERT_LT(first_scan, lines.size() - 1);
  std::vector<std::string> kept;
  std::size_t scans = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const bool is_scan = lines[i].rfind("scan ", 0) == 0, is_enc = lines[i].rfind("enc ", 0) == 0;
    if (is_scan && scans++ > 0) continue;     // the first scan only
    if (is_enc && i < first_scan) continue;   // no encoder record before it
    kept.push_back(lines[i]);
  }
  // Its stamp before the first encoder record left.
  const std::size_t e = lineOf(kept, "enc", 0), s = lineOf(kept, "scan", 0);
  std::vector<std::string> w = words(kept[s]);
  ASSERT_GE(w.size(), 3u);
  w[1] = std::to_string(std::stod(words(kept[e])[1]) - 0.01);
  kept[s] = unwords(w);
  Odolog log;
  std::string error;
  ASSERT_TRUE(parseOdolog(joinLines(kept), "early.odolog", &log, &error)) << error;
  ASSERT_EQ(log.scans.size(), 1u);
  ReplayOptions ro;
  ro.out_dir = test::tempDir("pipeline-early");
  ReplaySummary sum;
  ASSERT_TRUE(replayOdolog(log, ro, &sum, &error)) << error;
  EXPECT_EQ(sum.scans, 0u);
  EXPECT_EQ(sum.scans_late, 1u);
  EXPECT_EQ(test::checkPipeline(joinLines(kept), "early.odolog", ro.out_dir, true), "");
}
