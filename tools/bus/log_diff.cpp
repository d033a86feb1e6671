// log_diff: compares the messages of two LCM logs channel by channel (in order, byte for byte), to check
// that replaying one input twice through the processes gives identical outputs.
// Prints one line per channel and a last line "identical=1" or "identical=0".
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/framework/process.hpp"

namespace {

std::map<std::string, std::vector<std::vector<uint8_t>>> readLog(const std::string& path, const std::regex& channels) {
  lcm::LogFile log(path, "r");
  if (!log.good()) throw std::runtime_error("cannot read LCM log " + path);
  std::map<std::string, std::vector<std::vector<uint8_t>>> out;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    if (!std::regex_match(e->channel, channels)) continue;
    const auto* p = static_cast<const uint8_t*>(e->data);
    out[e->channel].emplace_back(p, p + e->datalen);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("log_diff", [&]() {
    ips::Args args(argc, argv, "compare two LCM logs message by message, per channel");
    args.option("--channels", "REGEX", "channels to compare (ECMAScript regex, whole name)",
                "TRACKER_DELTA|FILTER_.*|DISPARITY")
        .positionals("LOG", "the two logs", 2, 2);
    if (!args.parse()) return 0;
    const std::regex re(args.get("--channels"));
    auto a = readLog(args.positional()[0], re);
    auto b = readLog(args.positional()[1], re);
    bool same = !a.empty();
    std::map<std::string, int> names;
    for (const auto& kv : a) names[kv.first] = 1;
    for (const auto& kv : b) names[kv.first] = 1;
    for (const auto& kv : names) {
      const auto& ma = a[kv.first];
      const auto& mb = b[kv.first];
      size_t equal = 0;
      while (equal < ma.size() && equal < mb.size() && ma[equal] == mb[equal]) ++equal;
      const bool ok = ma.size() == mb.size() && equal == ma.size();
      same = same && ok;
      std::printf("channel=%s a=%zu b=%zu %s", kv.first.c_str(), ma.size(), mb.size(), ok ? "identical" : "DIFFERENT");
      if (!ok) std::printf(" first_difference_at=%zu", equal);
      std::printf("\n");
    }
    std::printf("identical=%d\n", same ? 1 : 0);
    return same ? 0 : 3;
  });
}
