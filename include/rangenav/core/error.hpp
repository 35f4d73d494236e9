#pragma once
// Errors raised at rangenav's API boundaries.
//
// Bad input is answered by an exception derived from rangenav::error that names the argument and
// the offending value. Invalid readings inside a scan (NaN, inf, 0, max range) are data, not
// errors; hot loops never throw.

#include <cmath>
#include <concepts>
#include <cstddef>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

namespace rangenav {

/// Base class of every exception rangenav throws.
class error : public std::runtime_error {
 public:
  /// An error with the message `what` (rangenav's messages start with "rangenav: ").
  explicit error(const std::string& what) : std::runtime_error(what) {}
};

/// A function argument violates its documented contract.
class invalid_argument : public error {
 public:
  /// An invalid-argument error with the message `what`, which names the argument and its value.
  explicit invalid_argument(const std::string& what) : error(what) {}
};

/// A file could not be opened, or its content is malformed (the message names file and line).
class io_error : public error {
 public:
  /// An I/O error with the message `what`, which names the file and, for text, the line.
  explicit io_error(const std::string& what) : error(what) {}
};

namespace detail {

template <class T>
std::string format_value(const T& value) {
  std::ostringstream out;
  if constexpr (std::is_floating_point_v<T>) out.precision(17);
  out << value;
  return out.str();
}

/// Throws invalid_argument("rangenav: <where>: argument '<name>' = <value> <requirement>").
template <class T>
[[noreturn]] void throw_invalid_argument(std::string_view where, std::string_view name,
                                         const T& value, std::string_view requirement) {
  std::string msg = "rangenav: ";
  msg.append(where).append(": argument '").append(name).append("' = ");
  msg.append(format_value(value)).append(" ").append(requirement);
  throw invalid_argument(msg);
}

/// Throws invalid_argument("rangenav: <where>: <message>") for contracts that involve no single
/// value (e.g. "cloud is empty").
[[noreturn]] inline void throw_invalid(std::string_view where, std::string_view message) {
  std::string msg = "rangenav: ";
  msg.append(where).append(": ").append(message);
  throw invalid_argument(msg);
}

/// Requires a finite number strictly greater than zero.
template <std::floating_point T>
void require_positive(std::string_view where, std::string_view name, T value) {
  if (!(std::isfinite(value) && value > T(0)))
    throw_invalid_argument(where, name, value, "must be finite and > 0");
}

/// Requires a finite number greater than or equal to zero.
template <std::floating_point T>
void require_non_negative(std::string_view where, std::string_view name, T value) {
  if (!(std::isfinite(value) && value >= T(0)))
    throw_invalid_argument(where, name, value, "must be finite and >= 0");
}

/// Requires a finite number.
template <std::floating_point T>
void require_finite(std::string_view where, std::string_view name, T value) {
  if (!std::isfinite(value)) throw_invalid_argument(where, name, value, "must be finite");
}

}  // namespace detail
}  // namespace rangenav
