// log_diff: compares the messages of two LCM logs channel by channel (in order, byte for byte), to check
// that replaying one input twice through the processes gives identical outputs.
// Prints one line per channel and a last line "identical=1" or "identical=0"; a damaged log is an error
// (exit 1) naming the file and the byte where it is damaged.
#include <cstdio>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/process.hpp"

namespace {

// Throws LogError (file, byte offset) when a log is truncated or corrupt: a damaged log is never "identical".
std::map<std::string, std::vector<std::vector<uint8_t>>> readLog(const std::string& path, const std::regex& channels) {
  ips::fw::LogReader log(path);
  std::map<std::string, std::vector<std::vector<uint8_t>>> out;
  ips::fw::LogMessage m;
  while (log.next(&m))
    if (std::regex_match(m.channel, channels)) out[m.channel].push_back(std::move(m.data));
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
