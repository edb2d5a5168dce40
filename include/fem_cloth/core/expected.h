// Errors as values. Every fallible core function returns Expected<T> (or Status) whose error
// message names the culprit: the key, the vertex, the triangle. Callers (the node, the tools)
// log the message, reject the input and keep their last good state.
#pragma once

#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace fem_cloth {

struct Error {
  std::string message;
};

/// A number as error messages and tables write it (ostream's default: 6 significant digits).
inline std::string numberText(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// Text taken from an input (a key, a frame or topic name, a type read from a bag) as messages
/// show it: one line (control characters as '?'), at most maxLength characters ("..." after).
inline std::string printableText(const std::string& text, std::size_t maxLength = 200) {
  std::string out;
  for (const char c : text.substr(0, maxLength)) {
    out += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '?' : c;
  }
  return text.size() > maxLength ? out + "..." : out;
}

/// A list as messages show it: "a, b, c" (the known keys, the supported integrators).
inline std::string commaList(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

template <typename T>
class Expected {
 public:
  Expected(T value) : content_(std::move(value)) {}  // NOLINT: implicit by design
  Expected(Error error) : content_(std::move(error)) {}  // NOLINT: implicit by design

  bool ok() const { return std::holds_alternative<T>(content_); }
  explicit operator bool() const { return ok(); }

  const T& value() const& { return std::get<T>(content_); }
  T& value() & { return std::get<T>(content_); }
  T&& value() && { return std::get<T>(std::move(content_)); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

  const std::string& error() const { return std::get<Error>(content_).message; }

 private:
  std::variant<T, Error> content_;
};

/// Success or an error message.
class Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error.message)) {}  // NOLINT: implicit by design
  static Status success() { return Status(); }

  bool ok() const { return !error_.has_value(); }
  explicit operator bool() const { return ok(); }
  const std::string& error() const { return *error_; }

 private:
  std::optional<std::string> error_;
};

}  // namespace fem_cloth

/// Returns the error of a Status-valued expression from the enclosing function (which returns a
/// Status or an Expected), and goes on when it succeeded.
#define FEM_CLOTH_CHECK(expr)     \
  do {                            \
    if (::fem_cloth::Status check_ = (expr); !check_) { \
      return ::fem_cloth::Error{check_.error()}; \
    }                             \
  } while (false)
