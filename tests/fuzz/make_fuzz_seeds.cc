// Writes seed inputs for the fuzzers: valid encodings of every message
// type (prefixed with the fuzzer's type byte). Usage: make_fuzz_seeds DIR
#include <cstdio>
#include <fstream>
#include <string>

#include "common/lcm_bus.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/decision_t.hpp"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/resend_t.hpp"
#include "imuqual/run_t.hpp"

template <typename T>
void Write(const std::string& dir, const std::string& name, uint8_t type, const T& msg) {
  std::vector<uint8_t> bytes;
  if (!imuqual::EncodeMessage(msg, &bytes).ok()) std::abort();
  std::ofstream out(dir + "/" + name, std::ios::binary);
  out.put(static_cast<char>(type));
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_fuzz_seeds DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  imuqual::rate_batch_t b{};
  b.run_id = "R";
  b.unit_serial = "U";
  b.seq = 3;
  b.first_sample = 300;
  b.nominal_rate_hz = 100;
  b.num_axes = 3;
  b.axis_names = {"a0", "a1", "a2"};
  b.axis_kinds = {1, 1, 2};
  b.num_samples = 4;
  b.samples = {{1, 2, 3, 4}, {0, 0, 0, 0}, {9.8f, 9.8f, 9.8f, 9.8f}};
  b.num_flagged = 1;
  b.flagged_sample = {2};
  b.flagged_axis = {1};
  b.flagged_bits = {1};
  Write(dir, "batch", 0, b);
  imuqual::run_t r{};
  r.run_id = "R";
  r.unit_serial = "U";
  r.nominal_rate_hz = 100;
  r.num_axes = 1;
  r.axis_names = {"x"};
  r.axis_kinds = {1};
  r.state = 1;
  Write(dir, "run", 1, r);
  imuqual::ack_t a{};
  a.process = "store";
  a.num_runs = 2;
  a.run_ids = {"R", "S"};
  a.next_seq = {7, 9};
  a.run_done = {false, true};
  Write(dir, "ack", 2, a);
  imuqual::resend_t s{};
  s.run_id = "R";
  s.first_seq = 1;
  s.last_seq = 5;
  Write(dir, "resend", 3, s);
  imuqual::decision_t d{};
  d.run_id = "R";
  d.unit_serial = "U";
  d.state = imuqual::decision_t::STATE_PENDING;
  d.looks_done = 3;
  d.looks_planned = 27;
  d.end_sample = 14000;
  d.z = 3.7;
  d.num_pending = 1;
  d.pending = {"x: tau_at_minimum: not yet on one side of a limit (z 3.7)"};
  Write(dir, "decision", 7, d);
  return 0;
}
