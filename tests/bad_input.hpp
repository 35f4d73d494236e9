#pragma once
// The bad-input tables: each row calls an entry point with one bad input and checks the outcome,
// a rangenav::error of the documented type whose message names the argument (or file, line and
// field), never another exception.

#include <catch2/catch.hpp>
#include <exception>
#include <string>
#include <typeinfo>

#include "rangenav/core/error.hpp"

namespace rangenav::test {

/// The message of the exception of type E (a rangenav::error subclass) that f() throws; a test
/// failure naming what happened instead, and "", when f() throws nothing or something else.
template <class E = rangenav::error, class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  } catch (const std::exception& e) {
    FAIL_CHECK("expected " << typeid(E).name() << ", got " << typeid(e).name() << ": " << e.what());
    return {};
  }
  FAIL_CHECK("expected " << typeid(E).name() << ", nothing was thrown");
  return {};
}

}  // namespace rangenav::test
