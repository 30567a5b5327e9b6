// Names of the core's enumerations (strategies, MIS modes, light-selection
// methods) looked up and listed from their own name tables, beside which each
// header declares its find_* and *_names (host code: the scene format and the
// command line read them; the kernels never do).
#pragma once

#include <string>

namespace pn {

// "a, b, c": every name of an enumeration of `count` values.
template <class E>
std::string enum_names(int count, const char* (*name)(E)) {
  std::string out;
  for (int i = 0; i < count; ++i) out += (i ? ", " : "") + std::string(name(E(i)));
  return out;
}

// The value named `text`; false where none is.
template <class E>
bool find_enum(const std::string& text, int count, const char* (*name)(E), E* out) {
  for (int i = 0; i < count; ++i)
    if (text == name(E(i))) {
      *out = E(i);
      return true;
    }
  return false;
}

}  // namespace pn
