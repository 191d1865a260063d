// Runs a callable when the scope ends, however it ends (return or exception): the switches a
// solver turns on for a while (own rows only, touching pairs closed) are turned off again.
#pragma once

#include <utility>

namespace peristat {

template <class F>
class ScopeExit {
 public:
  explicit ScopeExit(F f) : m_f(std::move(f)) {}
  ~ScopeExit() { m_f(); }
  ScopeExit(const ScopeExit&) = delete;
  ScopeExit& operator=(const ScopeExit&) = delete;

 private:
  F m_f;
};

}  // namespace peristat
