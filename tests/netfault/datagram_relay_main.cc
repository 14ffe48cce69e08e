// datagram_relay: relays the UDP datagrams an nftables rule diverts to it,
// late (reordered) and/or with a bit flipped (corrupted), as if from their
// sender. Flags -> RelayOptions -> DatagramRelay -> exit code (0 ok, 1
// failed, 2 bad options or sockets). Prints what it did when stopped
// (SIGTERM, SIGINT).
#include <CLI/CLI.hpp>
#include <iostream>

#include "common/log.h"
#include "common/shutdown.h"
#include "tests/netfault/datagram_relay.h"

int main(int argc, char** argv) {
  using namespace imuqual;
  netfault::RelayOptions opt;
  CLI::App app{"datagram_relay: relay diverted multicast datagrams late or damaged (tests)"};
  app.add_option("--listen-port", opt.listen_port, "port the datagrams are diverted to")
      ->required();
  app.add_option("--to-port", opt.to_port, "port they were meant for")->required();
  app.add_option("--group", opt.group, "multicast group")->capture_default_str();
  app.add_option("--delay-max-ms", opt.delay_max_ms, "hold each for uniform [0, this] ms")
      ->capture_default_str();
  app.add_option("--flip-probability", opt.flip_probability,
                 "probability of one payload bit flipped per datagram")
      ->capture_default_str();
  app.add_option("--mark", opt.mark, "SO_MARK of what the relay sends")->capture_default_str();
  app.add_option("--seed", opt.seed, "seed of delays and flips")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  SetLogProgramName("datagram_relay");
  InstallShutdownHandlers();
  auto relay = netfault::DatagramRelay::Open(opt);
  if (!relay.ok()) {
    LogError(relay.status().message());
    return 2;
  }
  LogInfo("relaying " + opt.group + ":" + std::to_string(opt.listen_port) + " to port " +
          std::to_string(opt.to_port));
  const Status st = (*relay)->Run();
  std::cout << "datagram_relay: " << (*relay)->Report() << std::endl;
  if (!st.ok()) {
    LogError(st.message());
    return 1;
  }
  return 0;
}
