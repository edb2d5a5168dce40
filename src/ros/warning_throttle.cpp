#include "fem_cloth/ros/warning_throttle.h"

#include <cctype>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

void WarningThrottle::close(const Window& w, std::vector<std::string>* lines) const {
  if (w.suppressed > 0) {
    lines->push_back(std::to_string(w.suppressed) + " more " + w.label + " in the " +
                     numberText(period_) + " s that followed (latest: " + w.latest + ")");
  }
}

std::vector<std::string> WarningThrottle::add(const std::string& kind, const std::string& message,
                                              double now, const std::string& label) {
  std::vector<std::string> lines;
  auto it = open_.find(kind);
  if (it != open_.end() && now - it->second.start < period_) {
    ++it->second.suppressed;
    it->second.latest = message;
    return lines;
  }
  if (it != open_.end()) close(it->second, &lines);
  open_[kind] = Window{now, 0, message, label.empty() ? kind : label};
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
    close(it->second, &lines);
    it = open_.erase(it);
  }
  return lines;
}

std::string WarningThrottle::kindOf(const std::string& message) {
  std::string kind;
  for (std::size_t i = 0; i < message.size();) {
    if (std::isdigit(static_cast<unsigned char>(message[i])) == 0) {
      kind += message[i++];
      continue;
    }
    kind += '#';
    while (i < message.size() &&
           (std::isdigit(static_cast<unsigned char>(message[i])) != 0 || message[i] == '.')) {
      ++i;
    }
  }
  return kind;
}

}  // namespace fem_cloth
