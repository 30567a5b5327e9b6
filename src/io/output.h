// Files penumbra writes: checked before any work starts, written atomically.
//
// Every output (images, JSON, CSV, .npy, scene files) goes through
// write_file_atomic: the bytes go to a temporary file in the target's own
// folder, every call is checked, the data is flushed to the disk (fsync) and the
// temporary file is renamed over the target. A failed write (full disk, I/O
// error, interruption) leaves the previous file as it was and throws one line;
// two processes writing one file leave one complete file, never a mixture.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace pn {

// Checks that `path` can be written as a file: it is not a folder, its folder
// exists and is writable. `option` names where the path came from in the
// message ("-o", "--variance", ...). Throws std::runtime_error with one line.
void check_output_file(const std::string& path, const std::string& option);

// Checks that `path` can hold output files: an existing writable folder, or one
// whose nearest existing ancestor is a writable folder (created later by the
// command). Throws std::runtime_error with one line.
void check_output_folder(const std::string& path, const std::string& option);

// Throws when two of the (option, path) outputs of one command are the same file.
void check_distinct_outputs(const std::vector<std::pair<std::string, std::string>>& outputs);

// Writes `size` bytes to `path` atomically (see above). Throws std::runtime_error
// "<path>: cannot write: <reason>" on any failure, after removing the temporary file.
void write_file_atomic(const std::string& path, const void* data, size_t size);
inline void write_file_atomic(const std::string& path, const std::string& text) {
  write_file_atomic(path, text.data(), text.size());
}

// Removes the temporary file of a write in progress, if any. Async-signal-safe:
// for a handler that ends the process on Ctrl-C (the target stays as it was).
void remove_partial_output();

}  // namespace pn
