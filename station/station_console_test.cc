#include "station/station_console.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <map>

#include "imuqual/decision_t.hpp"
#include "imuqual/measurement_t.hpp"
#include "imuqual/run_t.hpp"
#include "report/table_writer.h"

namespace imuqual::station {
namespace {

using imuqual::decision_t;
using imuqual::measurement_t;
using imuqual::run_t;
using report::DisplayWidth;

std::string Screen(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines) out += l + "\n";
  return out;
}

ConsoleUnit Unit(const std::string& slot, const std::string& serial, double elapsed_s,
                 int8_t verdict, bool final_result = false) {
  ConsoleUnit u;
  u.slot = slot;
  u.serial = serial;
  u.run_id = "R-" + serial;
  u.state = run_t::STATE_RUNNING;
  u.elapsed_s = elapsed_s;
  u.samples = static_cast<int64_t>(elapsed_s * 100);
  u.verdict = verdict;
  u.final_result = final_result;
  for (const char* name : {"x", "y", "z"}) {
    ConsoleAxis a;
    a.name = name;
    a.bias_instability = 10.25;
    a.unit = "deg/h";
    a.outcome = verdict;
    u.axes.push_back(a);
  }
  return u;
}

ConsoleModel Model() {
  ConsoleModel m;
  m.station = "bench-A";
  m.lot = "LOT-7";
  m.plan = "vg700ca-eol";
  m.operator_name = "ana";
  m.bus = "udpm://239.255.76.67:7700?ttl=0";
  m.archive = "lot.db";
  m.planned_s = 600;
  m.wall_s = 30;
  m.units.push_back(Unit("A1", "SN-1", 300, measurement_t::OUTCOME_PASS));
  m.units.push_back(Unit("A2", "SN-2", 300, measurement_t::OUTCOME_FAIL));
  ConsoleUnit waiting;
  waiting.slot = "A3";
  waiting.serial = "SN-3";
  m.units.push_back(waiting);
  ConsoleProcess store;
  store.name = "store";
  store.running = 1;
  store.restarts = 1;
  m.processes.push_back(store);
  return m;
}

TEST(StationConsoleTest, RowPerUnitAndAxisWhenTheScreenHoldsThem) {
  const std::string screen = Screen(RenderConsole(Model(), 160, 50));
  EXPECT_NE(screen.find("imuqual station bench-A   lot LOT-7   plan vg700ca-eol   operator ana"),
            std::string::npos)
      << screen;
  EXPECT_NE(screen.find("store up (restarted 1x)"), std::string::npos) << screen;
  EXPECT_NE(screen.find("5:00 / 10:00"), std::string::npos) << screen;
  EXPECT_NE(screen.find("10.2 deg/h"), std::string::npos) << screen;
  // Provisional verdicts are lower case with '?', per axis and per unit.
  EXPECT_NE(screen.find("pass?"), std::string::npos) << screen;
  EXPECT_NE(screen.find("fail?"), std::string::npos) << screen;
  EXPECT_EQ(screen.find("PASS"), std::string::npos) << screen;
  EXPECT_NE(screen.find("waiting"), std::string::npos) << screen;
  // Two of three units half way, one not started: a third done.
  EXPECT_NE(screen.find("[##########....................]  33%"), std::string::npos) << screen;
  // 3 + 3 axis rows and the waiting unit.
  int axis_rows = 0;
  for (const std::string& line : RenderConsole(Model(), 160, 50)) {
    axis_rows += line.find(" deg/h") != std::string::npos;
  }
  EXPECT_EQ(axis_rows, 6);
}

// Invalid samples (NaN, inf, bad cells, out of range) per axis, as they
// come: in the per-axis table its own column, in the per-unit table the
// axes that have any.
TEST(StationConsoleTest, InvalidSamplesAreShownPerAxis) {
  ConsoleModel m = Model();
  m.units[1].axes[1].invalid_samples = 37;
  const std::vector<std::string> wide = RenderConsole(m, 200, 50);
  const std::string screen = Screen(wide);
  EXPECT_NE(screen.find(" invalid"), std::string::npos) << screen;
  int rows_with_37 = 0;
  for (const std::string& line : wide) {
    if (line.find(" 37") == std::string::npos) continue;
    ++rows_with_37;
    EXPECT_NE(line.find(" y "), std::string::npos) << line;  // y's row, not the unit's first
  }
  EXPECT_EQ(rows_with_37, 1) << screen;
  // A screen too short for a row per axis: one row per unit.
  const std::string units = Screen(RenderConsole(m, 200, 12));
  EXPECT_NE(units.find("y 37"), std::string::npos) << units;
}

TEST(StationConsoleTest, FinalVerdictsAreUpperCase) {
  ConsoleModel m = Model();
  m.units[0].final_result = true;
  m.units[0].archived = true;
  const std::string screen = Screen(RenderConsole(m, 160, 50));
  EXPECT_NE(screen.find("PASS"), std::string::npos) << screen;
  EXPECT_NE(screen.find("done"), std::string::npos) << screen;
}

// INCONCLUSIVE, ABORTED and ERROR are shown as such, and the tally's yield
// counts the units judged PASS, MARGINAL or FAIL only.
TEST(StationConsoleTest, EveryOutcomeIsShownAndTheYieldCountsJudgedUnitsOnly) {
  ConsoleModel m = Model();
  m.units.clear();
  m.units.push_back(Unit("A1", "SN-1", 600, measurement_t::OUTCOME_PASS, true));
  m.units.push_back(Unit("A2", "SN-2", 600, measurement_t::OUTCOME_FAIL, true));
  m.units.push_back(Unit("A3", "SN-3", 600, measurement_t::OUTCOME_INCONCLUSIVE, true));
  m.units.push_back(Unit("B1", "SN-4", 100, measurement_t::OUTCOME_ABORTED, true));
  m.units.push_back(Unit("B2", "SN-5", 10, measurement_t::OUTCOME_ERROR, true));
  m.units.push_back(Unit("B3", "SN-6", 300, measurement_t::OUTCOME_UNSET));
  const std::string screen = Screen(RenderConsole(m, 160, 50));
  for (const char* shown : {"INCONCLUSIVE", "ABORTED", "ERROR", "FAIL", "PASS"}) {
    EXPECT_NE(screen.find(shown), std::string::npos) << shown << "\n" << screen;
  }
  // 1 of the 2 units judged PASS, MARGINAL or FAIL passes: 50 %, not 1 of
  // 5; SN-6 is not final yet, so the tally is not "final" either
  EXPECT_EQ(ConsoleTally(m),
            "so far (5 of 6 units final): 1 PASS, 0 MARGINAL, 1 FAIL, 1 INCONCLUSIVE, 1 ABORTED, "
            "1 ERROR; yield 50% of 2 judged units");
  EXPECT_NE(screen.find(ConsoleTally(m)), std::string::npos) << screen;
  // AND once the last unit is judged, the tally is final
  m.units[5].verdict = measurement_t::OUTCOME_FAIL;
  m.units[5].final_result = true;
  EXPECT_EQ(ConsoleTally(m),
            "final: 1 PASS, 0 MARGINAL, 2 FAIL, 1 INCONCLUSIVE, 1 ABORTED, 1 ERROR; yield 33% of 3 "
            "judged units");
  m.units[5].verdict = measurement_t::OUTCOME_UNSET;
  m.units[5].final_result = false;
  // AND provisional: lower case with '?', and an interim INCONCLUSIVE (a
  // value that can still change side) reads "pending", said in the legend;
  // the per-unit table marks an inconclusive value '?', and lists the FAIL
  // first, then ERROR, ABORTED, INCONCLUSIVE
  m.units[2].final_result = false;
  const std::string interim = Screen(RenderConsole(m, 160, 50));
  EXPECT_NE(interim.find("pending"), std::string::npos) << interim;
  EXPECT_EQ(interim.find("inconclusive?"), std::string::npos) << interim;
  EXPECT_NE(interim.find("pending: may still change side"), std::string::npos) << interim;
  const std::string small = Screen(RenderConsole(m, 120, 15));  // with the marks' legend
  EXPECT_NE(small.find("10.2?"), std::string::npos) << small;
  EXPECT_LT(small.find("SN-2"), small.find("SN-5")) << small;
  EXPECT_LT(small.find("SN-5"), small.find("SN-4")) << small;
  // AND no judged unit: the yield is not measurable
  m.units.erase(m.units.begin(), m.units.begin() + 3);
  EXPECT_NE(ConsoleTally(m).find("yield not measurable: no judged unit"), std::string::npos)
      << ConsoleTally(m);
}

TEST(StationConsoleTest, SmallScreenShowsAUnitPerRowAttentionFirst) {
  ConsoleModel m = Model();
  for (int i = 4; i <= 40; ++i) {
    std::string slot = "A", serial = "SN-";
    slot += std::to_string(i);
    serial += std::to_string(i);
    m.units.push_back(Unit(slot, serial, 100, measurement_t::OUTCOME_PASS));
  }
  m.units.push_back(Unit("A41", "SN-41", 100, measurement_t::OUTCOME_MARGINAL));
  const std::vector<std::string> lines = RenderConsole(m, 120, 20);
  const std::string screen = Screen(lines);
  EXPECT_LE(lines.size(), 20u);
  for (const std::string& l : lines) EXPECT_LE(l.size(), 120u);
  // Axes side by side, FAIL and MARGINAL units listed before the rest.
  const auto header = std::find_if(lines.begin(), lines.end(),
                                   [](const std::string& l) { return l.rfind("slot", 0) == 0; });
  ASSERT_NE(header, lines.end()) << screen;
  for (const char* column : {"  x  ", "  y  ", "  z  ", "verdict"}) {
    EXPECT_NE(header->find(column), std::string::npos) << *header;
  }
  const size_t fail = screen.find("SN-2 "), marginal = screen.find("SN-41"),
               pass = screen.find("SN-1 ");
  ASSERT_NE(fail, std::string::npos) << screen;
  ASSERT_NE(marginal, std::string::npos) << screen;
  EXPECT_LT(fail, marginal);
  if (pass != std::string::npos) {
    EXPECT_LT(marginal, pass);
  }
  EXPECT_NE(screen.find("10.2!"), std::string::npos) << screen;
  EXPECT_NE(screen.find("10.2~"), std::string::npos) << screen;
  EXPECT_NE(screen.find("more units ("), std::string::npos) << screen;
}

// At 80x24 (a terminal's default), eight 3-axis units: each row starts with
// what the operator acts on (slot, unit, verdict, why), FAIL first, a legend
// for the marks, a silent unit and a failed source said as such, colour only
// when asked.
TEST(StationConsoleTest, EightyByTwentyFourShowsVerdictsAndReasonsFirst) {
  ConsoleModel m = Model();
  m.units.clear();
  for (int i = 1; i <= 8; ++i) {
    m.units.push_back(Unit("A" + std::to_string(i), "SN-10" + std::to_string(i), 300,
                           measurement_t::OUTCOME_PASS));
  }
  m.units[5].verdict = measurement_t::OUTCOME_FAIL;
  m.units[5].axes[1].outcome = measurement_t::OUTCOME_FAIL;
  m.units[5].reason = "y: bias_instability 31.2 deg/h above high limit 30 deg/h";
  m.units[2].silent_s = 12;
  m.units[3].source_failed = true;
  m.units[3].state = run_t::STATE_ABORTED;
  const std::vector<std::string> lines = RenderConsole(m, 80, 24);
  const std::string screen = Screen(lines);
  EXPECT_LE(lines.size(), 24u);
  for (const std::string& l : lines) EXPECT_LE(DisplayWidth(l), 80u) << l;
  // The failing unit first, its verdict and the start of its reason on its row.
  const auto header = std::find_if(lines.begin(), lines.end(),
                                   [](const std::string& l) { return l.rfind("slot", 0) == 0; });
  ASSERT_NE(header, lines.end()) << screen;
  ASSERT_LT(header + 2, lines.end());
  const std::string& first = *(header + 2);
  EXPECT_NE(first.find("SN-106"), std::string::npos) << screen;
  EXPECT_NE(first.find("fail?"), std::string::npos) << screen;
  EXPECT_NE(first.find("y: bias_instability"), std::string::npos) << screen;
  for (const ConsoleUnit& u : m.units) {
    const auto row = std::find_if(lines.begin(), lines.end(), [&](const std::string& l) {
      return l.find(u.serial) != std::string::npos;
    });
    ASSERT_NE(row, lines.end()) << u.serial << "\n" << screen;
    EXPECT_TRUE(row->find("pass?") != std::string::npos || row->find("fail?") != std::string::npos)
        << *row;
  }
  EXPECT_NE(screen.find("no data 0:12"), std::string::npos) << screen;
  EXPECT_NE(screen.find("source failed"), std::string::npos) << screen;
  EXPECT_NE(screen.find("BI value: ! fail  ~ marginal"), std::string::npos) << screen;
  EXPECT_NE(screen.find("pass? fail?: provisional"), std::string::npos) << screen;
  // No escape codes unless asked; asked, the verdicts are coloured and the
  // lines keep their width.
  EXPECT_EQ(screen.find('\x1b'), std::string::npos);
  const std::vector<std::string> colored = RenderConsole(m, 80, 24, /*color=*/true);
  const std::string colored_screen = Screen(colored);
  EXPECT_NE(colored_screen.find("\x1b[31mfail?\x1b[0m"), std::string::npos);
  EXPECT_NE(colored_screen.find("\x1b[1;31msource failed\x1b[0m"), std::string::npos);
  ASSERT_EQ(colored.size(), lines.size());
  for (size_t i = 0; i < lines.size(); ++i) {
    std::string plain;
    for (size_t k = 0; k < colored[i].size(); ++k) {
      if (colored[i][k] == '\x1b') {
        k = colored[i].find('m', k);
        continue;
      }
      plain += colored[i][k];
    }
    EXPECT_EQ(plain, lines[i]);
  }
}

// Colour goes to the verdict and state cells only: a serial, a slot or a
// reason that reads like a verdict stays plain. A unit whose device is gone
// shows "reconnecting M:SS" and is listed with the units needing attention.
TEST(StationConsoleTest, ColourOnlyInVerdictAndStateCellsAndReconnectingShown) {
  ConsoleModel m = Model();
  m.units.clear();
  for (int i = 1; i <= 3; ++i) {
    m.units.push_back(Unit("PASS", "FAIL-0" + std::to_string(i), 300, measurement_t::OUTCOME_PASS));
  }
  m.units[1].verdict = measurement_t::OUTCOME_FAIL;
  m.units[1].reason = "FAIL x: PASS";
  m.units[2].reconnecting = true;
  m.units[2].silent_s = 9;
  m.units[2].verdict = measurement_t::OUTCOME_FAIL;
  m.units[2].reason = "x: bias_instability 31 \u00b1 2 \u2264 deg/h";  // bytes != columns
  const std::vector<std::string> plain = RenderConsole(m, 140, 45);
  const std::string screen = Screen(plain);
  EXPECT_NE(screen.find("reconnecting 0:09"), std::string::npos) << screen;
  const std::string colored = Screen(RenderConsole(m, 140, 45, /*color=*/true));
  EXPECT_NE(colored.find("\x1b[1;33mreconnecting 0:09\x1b[0m"), std::string::npos) << colored;
  EXPECT_NE(colored.find("\x1b[31mfail?\x1b[0m"), std::string::npos) << colored;
  // The row whose reason has multi-byte characters before its state keeps
  // its colours.
  const size_t row3 = colored.find("FAIL-03");
  ASSERT_NE(row3, std::string::npos);
  const std::string row = colored.substr(row3, colored.find('\n', row3) - row3);
  EXPECT_NE(row.find("\x1b[1;33mreconnecting 0:09\x1b[0m"), std::string::npos) << row;
  EXPECT_NE(row.find("\x1b[31mfail?\x1b[0m"), std::string::npos) << row;
  // Serials, slots and the reason: never coloured.
  for (const char* text : {"FAIL-01", "FAIL-02", "FAIL-03", "FAIL x: PASS"}) {
    const size_t at = colored.find(text);
    ASSERT_NE(at, std::string::npos) << text << "\n" << colored;
    EXPECT_NE(colored[at == 0 ? 0 : at - 1], 'm') << text << "\n" << colored;
  }
  EXPECT_EQ(colored.find("\x1b[1;32mPASS"), std::string::npos) << colored;  // the slot name
  // At 80x24 with more units than rows, the reconnecting unit comes first.
  for (int i = 4; i <= 12; ++i) {
    m.units.push_back(
        Unit("A" + std::to_string(i), "SN-" + std::to_string(i), 300, measurement_t::OUTCOME_PASS));
  }
  m.units[1].verdict = measurement_t::OUTCOME_PASS;
  m.units[1].reason.clear();
  m.units[2].verdict = measurement_t::OUTCOME_PASS;
  m.units[2].reason.clear();
  const std::string small = Screen(RenderConsole(m, 80, 24));
  const size_t reconnecting = small.find("FAIL-03"), other = small.find("SN-4 ");
  ASSERT_NE(reconnecting, std::string::npos) << small;
  if (other != std::string::npos) {
    EXPECT_LT(reconnecting, other) << small;
  }
}

// The provisional values carry the marks measurement_t gives them.
TEST(StationConsoleTest, LiveValuesCarryTheirMarksAndALegend) {
  ConsoleModel m = Model();
  m.units[0].axes[0].bias_instability_uncertainty = 0.81;
  m.units[0].axes[1].bias_instability_qualifier = measurement_t::QUALIFIER_MINIMUM_NOT_RESOLVED;
  m.units[0].axes[2].bias_instability_qualifier = measurement_t::QUALIFIER_UPPER_BOUND;
  m.units[1].axes[0].bias_instability = std::numeric_limits<double>::quiet_NaN();
  m.units[1].axes[0].bias_instability_qualifier = measurement_t::QUALIFIER_NOT_MEASURABLE;
  // Provisional: not measurable yet is not there yet.
  EXPECT_EQ(Screen(RenderConsole(m, 160, 40)).find("n/m"), std::string::npos);
  m.units[1].final_result = true;
  m.units[1].axes[1].bias_instability_qualifier = measurement_t::QUALIFIER_MODEL_INADEQUATE;
  const std::string screen = Screen(RenderConsole(m, 160, 40));
  for (const char* shown :
       {"10.25 \u00B1 0.81 deg/h", "10.2\u2020 deg/h", "\u2264 10.2 deg/h", "n/m deg/h",
        "10.2\u2021 deg/h", "\u2020 minimum at the last point", "\u2021 noise model failed its fit",
        "n/m not measurable", "\u2264 upper bound"}) {
    EXPECT_NE(screen.find(shown), std::string::npos) << shown << "\n" << screen;
  }
  // A unit per row: the marks without the uncertainty, the legend kept.
  const std::string small = Screen(RenderConsole(m, 160, 12));
  EXPECT_NE(small.find("10.2\u2021!"), std::string::npos) << small;  // SN-2, failed, first
  EXPECT_NE(small.find("n/m!"), std::string::npos) << small;
  EXPECT_NE(small.find("\u2021 noise model failed its fit"), std::string::npos) << small;
  // Cut to the width in columns, never inside a character.
  for (const std::string& line : RenderConsole(m, 23, 40)) {
    size_t columns = 0;
    for (unsigned char c : line) columns += (c & 0xC0) != 0x80;
    EXPECT_LE(columns, 23u) << line;
    if (!line.empty()) {
      EXPECT_NE(static_cast<unsigned char>(line.back()) & 0xC0, 0xC0) << line;
    }
  }
}

// Early decisions: no provisional verdict a later look may overturn.
TEST(StationConsoleTest, EarlyDecisionUnitsShowPendingLooksThenTheirDecision) {
  // GIVEN a plan with 27 looks: SN-1 pending at look 5 on axis y, SN-2
  // decided FAIL at 14 min, both with a provisional FAIL on axis x
  ConsoleModel m = Model();
  m.units.pop_back();
  for (ConsoleUnit& u : m.units) {
    u.looks_planned = 27;
    u.verdict = measurement_t::OUTCOME_FAIL;
    u.axes[0].outcome = measurement_t::OUTCOME_FAIL;
    u.axes[1].outcome = measurement_t::OUTCOME_PASS;
    u.axes[2].outcome = measurement_t::OUTCOME_PASS;
  }
  m.units[0].looks_done = 5;
  m.units[0].decision = decision_t::STATE_PENDING;
  m.units[0].pending = {"y: bias_instability 12 ± 3 deg/h: not yet on one side of a limit (z 3.7)"};
  m.units[1].looks_done = 12;
  m.units[1].decision = decision_t::STATE_FAIL;
  m.units[1].decided_at_s = 840;
  const std::vector<std::string> lines = RenderConsole(m, 160, 50);
  const std::string screen = Screen(lines);
  // THEN the pending unit reads PENDING with its looks, its axes pending or
  // passed, and no "fail?" that a later look could overturn
  auto row_of = [&](const std::string& serial, const std::string& axis) {
    for (size_t i = 0; i < lines.size(); ++i) {
      if (lines[i].find(serial) == std::string::npos) continue;
      for (size_t k = i; k < lines.size() && k < i + 3; ++k) {
        if (lines[k].find("  " + axis + "  ") != std::string::npos) return lines[k];
      }
    }
    return std::string();
  };
  EXPECT_NE(row_of("SN-1", "x").find("PENDING look 5/27"), std::string::npos) << screen;
  EXPECT_EQ(row_of("SN-1", "x").find("fail"), std::string::npos) << screen;
  EXPECT_NE(row_of("SN-1", "y").find("pending"), std::string::npos) << screen;
  EXPECT_NE(row_of("SN-1", "z").find("pass"), std::string::npos) << screen;
  // AND the decided one says so, with its time, and frees its slot
  EXPECT_NE(screen.find("decided FAIL at 14m"), std::string::npos) << screen;
  EXPECT_NE(screen.find("slot free"), std::string::npos) << screen;
  EXPECT_NEAR(ConsoleProgress(m), (0.5 + 1.0) / 2, 1e-12);
  // AND a unit per row, more units than fit: the same words, the decided
  // failure first (pending units rank by their decision, not by their
  // provisional FAIL), no mark on a pending unit's values
  for (const char* serial : {"SN-3", "SN-4", "SN-5"}) {
    ConsoleUnit u = m.units[0];
    u.serial = serial;
    m.units.insert(m.units.begin(), u);
  }
  const std::vector<std::string> small_lines = RenderConsole(m, 120, 13);  // with the legend
  const std::string small = Screen(small_lines);
  ASSERT_NE(small.find("SN-2"), std::string::npos) << small;
  EXPECT_NE(small.find("3 not judged yet)"), std::string::npos) << small;
  EXPECT_NE(small.find("PENDING look 5/27"), std::string::npos) << small;
  EXPECT_NE(small.find("decided FAIL at 14m"), std::string::npos) << small;
  for (const std::string& line : small_lines) {
    EXPECT_LE(DisplayWidth(line), 120u) << line;
    if (line.find("PENDING") != std::string::npos) {
      EXPECT_EQ(line.find('!'), std::string::npos) << line;
    }
  }
  m.units.erase(m.units.begin(), m.units.begin() + 3);
  // AND once judged, the final verdict in capitals
  m.units[1].final_result = true;
  m.units[1].archived = true;
  const std::string done = Screen(RenderConsole(m, 160, 50));
  EXPECT_NE(done.find("FAIL"), std::string::npos) << done;
  EXPECT_EQ(done.find("decided FAIL"), std::string::npos) << done;
  EXPECT_NE(done.find("done"), std::string::npos) << done;
  // AND without early decisions nothing changes: provisional verdicts.
  for (ConsoleUnit& u : m.units) u.looks_planned = 0;
  EXPECT_NE(Screen(RenderConsole(m, 160, 50)).find("fail?"), std::string::npos);
}

TEST(StationConsoleTest, ProgressCountsArchivedRunsAsDone) {
  ConsoleModel m = Model();
  EXPECT_NEAR(ConsoleProgress(m), (0.5 + 0.5 + 0) / 3, 1e-12);
  for (ConsoleUnit& u : m.units) u.archived = true;
  EXPECT_DOUBLE_EQ(ConsoleProgress(m), 1.0);
  m.planned_s = 0;  // recordings of unknown length: runs archived
  m.units[2].archived = false;
  EXPECT_NEAR(ConsoleProgress(m), 2.0 / 3, 1e-12);
  EXPECT_NE(ConsoleSummaryLine(m).find("runs archived 2/3"), std::string::npos);
}

TEST(StationConsoleTest, Durations) {
  EXPECT_EQ(FormatDuration(0), "0:00");
  EXPECT_EQ(FormatDuration(59.6), "1:00");
  EXPECT_EQ(FormatDuration(3599), "59:59");
  EXPECT_EQ(FormatDuration(7325), "2:02:05");
  EXPECT_EQ(FormatDuration(-3), "0:00");
}

}  // namespace
}  // namespace imuqual::station

namespace imuqual::station {
namespace {

// The cells of the table that starts at the line beginning "slot": one map
// per row from column name to its text (trimmed), columns read off the rule
// of dashes (display columns: a cell may hold a multi-byte "±").
std::vector<std::map<std::string, std::string>> TableCells(const std::vector<std::string>& lines) {
  std::vector<std::map<std::string, std::string>> out;
  auto header = std::find_if(lines.begin(), lines.end(),
                             [](const std::string& l) { return l.rfind("slot", 0) == 0; });
  if (header == lines.end() || header + 1 == lines.end()) return out;
  const std::string& dashes = *(header + 1);
  std::vector<std::pair<size_t, size_t>> spans;
  for (size_t at = dashes.find('-'); at != std::string::npos;) {
    const size_t end = std::min(dashes.find(' ', at), dashes.size());
    spans.emplace_back(at, end);
    at = dashes.find('-', end);
  }
  auto cell = [](const std::string& line, size_t from, size_t to) {
    std::vector<size_t> byte_of;
    for (size_t b = 0; b < line.size(); ++b) {
      if ((static_cast<unsigned char>(line[b]) & 0xC0) != 0x80) byte_of.push_back(b);
    }
    byte_of.push_back(line.size());
    if (from >= byte_of.size() - 1) return std::string();
    const size_t b0 = byte_of[from], b1 = byte_of[std::min(to, byte_of.size() - 1)];
    std::string text = line.substr(b0, b1 - b0);
    text.erase(text.find_last_not_of(' ') + 1);
    text.erase(0, std::min(text.size(), text.find_first_not_of(' ')));
    return text;
  };
  for (auto row = header + 2; row != lines.end() && !row->empty(); ++row) {
    if (!(row->rfind("A", 0) == 0 || row->rfind(" ", 0) == 0)) break;  // the legend (slots A1...)
    std::map<std::string, std::string> cells;
    for (const auto& [from, to] : spans) cells[cell(*header, from, to)] = cell(*row, from, to);
    out.push_back(cells);
  }
  return out;
}

// Issue 30: at 80 x 24 the BI column showed 30.2 deg/h as "3". At every
// terminal size a column is left out whole or shown whole: every cell on a
// narrow screen is the same text as on a screen wide enough for every
// column, and every line fits.
TEST(StationConsoleTest, ANumberIsShownWholeOrNotAtAllAtEverySize) {
  for (int units : {4, 8}) {
    ConsoleModel m = Model();
    m.units.clear();
    const double values[] = {30.2, 11.3, 9.87, 104.5, 0.0123, 7.0};
    for (int i = 1; i <= units; ++i) {
      ConsoleUnit u = Unit("A" + std::to_string(i), "SN-20" + std::to_string(i), 300 + 7 * i,
                           measurement_t::OUTCOME_PASS);
      for (size_t a = 0; a < u.axes.size(); ++a) {
        u.axes[a].bias_instability = values[(i + a) % 6];
        u.axes[a].bias_instability_uncertainty = 0.1 * values[(i + a) % 6];
      }
      m.units.push_back(u);
    }
    m.units[1].verdict = measurement_t::OUTCOME_FAIL;
    m.units[1].axes[0].outcome = measurement_t::OUTCOME_FAIL;
    m.units[1].reason = "x: bias_instability 30.2 ± 3.0 deg/h, limit <= 20";
    m.units[2].axes[1].bias_instability_qualifier = measurement_t::QUALIFIER_MINIMUM_NOT_RESOLVED;
    for (const auto& [width, height] : {std::pair{80, 24}, std::pair{100, 30}, std::pair{140, 45}}) {
      const std::vector<std::string> narrow = RenderConsole(m, width, height);
      const std::vector<std::string> wide = RenderConsole(m, 1000, height);
      const std::string screen = Screen(narrow);
      for (const std::string& l : narrow) EXPECT_LE(DisplayWidth(l), static_cast<size_t>(width)) << l;
      const auto cut = TableCells(narrow), whole = TableCells(wide);
      ASSERT_EQ(cut.size(), whole.size()) << width << "x" << height << "\n" << screen;
      ASSERT_FALSE(cut.empty()) << screen;
      for (size_t r = 0; r < cut.size(); ++r) {
        for (const auto& [column, text] : cut[r]) {
          ASSERT_TRUE(whole[r].count(column)) << column;
          if (column == "why" && text.ends_with("...")) {
            // A reason cut to the room left: whole words of it, the last one
            // a whole word of the full reason, never a dangling "±".
            const std::string kept = text.substr(0, text.size() - 3);
            const std::string& full = whole[r].at(column);
            EXPECT_EQ(full.rfind(kept, 0), 0u) << text << " / " << full;
            EXPECT_TRUE(kept.size() < full.size() &&
                        (full[kept.size()] == ' ' || full[kept.size()] == ','))
                << text;
            EXPECT_FALSE(kept.ends_with("\u00b1")) << text;
            continue;
          }
          EXPECT_EQ(text, whole[r].at(column))
              << units << " units at " << width << "x" << height << ", row " << r << " column "
              << column << "\n" << screen;
        }
        // The verdict and the unit are always there.
        EXPECT_TRUE(cut[r].count("verdict") && cut[r].count("serial")) << screen;
      }
      // The failing unit first, with why when the screen has room for it.
      EXPECT_EQ(cut[0].at("serial"), "SN-202") << screen;
      // The marks' legend only for values on screen.
      bool values_shown = false;
      for (const auto& [column, text] : cut[0]) {
        values_shown |= column == "BI (live)" || column == "x" || column == "y" || column == "z";
      }
      // (the dagger's legend, for the unresolved minimum of SN-203 y)
      EXPECT_EQ(values_shown, screen.find("minimum at the last point") != std::string::npos)
          << screen;
    }
  }
}

}  // namespace
}  // namespace imuqual::station
