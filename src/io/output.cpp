#include "io/output.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace pn {
namespace fs = std::filesystem;

namespace {

std::string folder_of(const std::string& path) {
  fs::path p(path);
  return p.has_parent_path() ? p.parent_path().string() : std::string(".");
}

std::string errno_text(int e) { return std::strerror(e); }

// The temporary file being written, for remove_partial_output() (a signal
// handler): a fixed buffer, since a handler may not touch a std::string.
char g_partial[4096] = {0};
volatile std::sig_atomic_t g_has_partial = 0;

}  // namespace

void check_output_file(const std::string& path, const std::string& option) {
  const std::string where = option + " " + path;
  if (path.empty()) throw std::runtime_error(option + ": empty file name");
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw std::runtime_error(where + ": is a folder, not a file");
  const std::string dir = folder_of(path);
  if (!fs::exists(dir, ec)) throw std::runtime_error(where + ": the folder '" + dir + "' does not exist");
  if (!fs::is_directory(dir, ec)) throw std::runtime_error(where + ": '" + dir + "' is not a folder");
  if (access(dir.c_str(), W_OK | X_OK) != 0)
    throw std::runtime_error(where + ": the folder '" + dir + "' is not writable (" + errno_text(errno) + ")");
}

void check_output_folder(const std::string& path, const std::string& option) {
  const std::string where = option + " " + path;
  if (path.empty()) throw std::runtime_error(option + ": empty folder name");
  std::error_code ec;
  fs::path p = fs::absolute(path, ec);
  if (ec) throw std::runtime_error(where + ": " + ec.message());
  // The nearest ancestor that exists must be a writable folder: the command
  // creates the rest.
  fs::path existing = p;
  while (!fs::exists(existing, ec) && existing.has_parent_path() && existing != existing.parent_path())
    existing = existing.parent_path();
  if (!fs::is_directory(existing, ec))
    throw std::runtime_error(where + ": '" + existing.string() + "' is " +
                             (existing == p ? "a file, not a folder" : "a file, so the folder cannot be created"));
  if (access(existing.c_str(), W_OK | X_OK) != 0)
    throw std::runtime_error(where + ": '" + existing.string() + "' is not writable (" + errno_text(errno) + ")");
}

void check_distinct_outputs(const std::vector<std::pair<std::string, std::string>>& outputs) {
  std::vector<fs::path> canon;
  for (const auto& [option, path] : outputs) {
    std::error_code ec;
    const fs::path abs = fs::absolute(path, ec).lexically_normal();
    fs::path c = fs::weakly_canonical(abs, ec);  // also through symbolic links
    canon.push_back(ec ? abs : c);
  }
  for (size_t i = 0; i < outputs.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (canon[i] == canon[j])
        throw std::runtime_error(outputs[j].first + " " + outputs[j].second + " and " + outputs[i].first + " " +
                                 outputs[i].second + " are the same file: one would overwrite the other");
}

void write_file_atomic(const std::string& path, const void* data, size_t size) {
  auto fail = [&](const std::string& why) -> void { throw std::runtime_error(path + ": cannot write: " + why); };
  const fs::path target(path);
  const std::string dir = folder_of(path);
  std::string tmpl = (fs::path(dir) / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  if (tmpl.size() >= sizeof g_partial) fail("the path is too long");
  std::vector<char> name(tmpl.begin(), tmpl.end());
  name.push_back('\0');
  int fd = mkstemp(name.data());
  if (fd < 0) fail("cannot create a temporary file in '" + dir + "' (" + errno_text(errno) + ")");
  const std::string tmp(name.data());
  std::memcpy(g_partial, name.data(), name.size());
  g_has_partial = 1;
  auto abandon = [&](const std::string& why) {
    int e = errno;
    if (fd >= 0) close(fd);
    unlink(tmp.c_str());
    g_has_partial = 0;
    errno = e;
    fail(why + " (" + errno_text(e) + ")");
  };
  // mkstemp makes the file private (0600); give it the mode a new file gets.
  mode_t mask = umask(0);
  umask(mask);
  if (fchmod(fd, 0666 & ~mask) != 0) abandon("cannot set the temporary file's mode");
  const char* p = static_cast<const char*>(data);
  size_t left = size;
  while (left > 0) {
    ssize_t n = write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = EIO;
      abandon("write failed after " + std::to_string(size - left) + " of " + std::to_string(size) + " bytes");
    }
    p += n;
    left -= size_t(n);
  }
  if (fsync(fd) != 0) abandon("cannot flush the data to the disk");
  int rc = close(fd);
  fd = -1;
  if (rc != 0) abandon("closing the file failed");
  if (std::rename(tmp.c_str(), path.c_str()) != 0) abandon("cannot rename the temporary file over it");
  g_has_partial = 0;
  // The rename itself reaches the disk with the folder's entry.
  int dfd = open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dfd >= 0) {
    fsync(dfd);  // best effort: some file systems refuse fsync on folders
    close(dfd);
  }
}

void remove_partial_output() {
  if (g_has_partial) unlink(g_partial);
}

}  // namespace pn
