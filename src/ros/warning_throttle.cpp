#include "fem_cloth/ros/warning_throttle.h"

#include <algorithm>
#include <cctype>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

void WarningThrottle::close(const std::string& kind, Window& w,
                            std::vector<std::string>* lines) const {
  if (w.suppressed > 0) {
    lines->push_back(std::to_string(w.suppressed) + " more " + kind + " in the " +
                     numberText(period_) + " s that followed (latest: " + w.latest + ")");
  }
}

std::vector<std::string> WarningThrottle::add(const std::string& kind, const std::string& message,
                                              double now) {
  std::vector<std::string> lines;
  auto it = open_.find(kind);
  if (it != open_.end() && now - it->second.start < period_) {
    ++it->second.suppressed;
    it->second.latest = message;
    return lines;
  }
  if (it != open_.end()) close(kind, it->second, &lines);
  open_[kind] = Window{now, 0, message};
  lines.push_back(message);
  return lines;
}

std::vector<std::string> WarningThrottle::flush(double now) {
  std::vector<std::string> lines;
  for (auto it = open_.begin(); it != open_.end();) {
    if (now - it->second.start < period_) {
      ++it;
      continue;
    }
    close(it->first, it->second, &lines);
    it = open_.erase(it);
  }
  return lines;
}

std::string WarningThrottle::kindOf(const std::string& message) {
  std::string kind = message;
  std::replace_if(kind.begin(), kind.end(), [](unsigned char c) { return std::isdigit(c) != 0; }, '#');
  return kind;
}

}  // namespace fem_cloth
