// Errors as values. Every fallible core function returns Expected<T> (or Status) whose error
// message names the culprit: the key, the vertex, the triangle. Callers (the node, the tools)
// log the message, reject the input and keep their last good state.
#pragma once

#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <variant>

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
