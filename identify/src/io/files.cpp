#include "kincal/identify/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace fs = std::filesystem;

namespace {

std::string os_error(int err) { return std::strerror(err); }

std::string mib(std::size_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

// write(2) until done; false with errno set on a failure.
bool write_all(int fd, const std::string& text) {
  const char* p = text.data();
  std::size_t left = text.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    p += n;
    left -= std::size_t(n);
  }
  return true;
}

// Writes, syncs and closes; throws naming `shown` on any failure (the
// temporary, if any, is the caller's to remove).
void write_fd(int fd, const std::string& text, const std::string& shown, bool sync) {
  if (!write_all(fd, text)) {
    const int err = errno;
    ::close(fd);
    throw InputError(shown, 0, 0, "write failed: " + os_error(err));
  }
  if (sync && ::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    throw InputError(shown, 0, 0, "write failed (flush to disk): " + os_error(err));
  }
  if (::close(fd) != 0) throw InputError(shown, 0, 0, "write failed (close): " + os_error(errno));
}

bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (fs::path(a).lexically_normal() == fs::path(b).lexically_normal()) return true;
  const bool eq = fs::equivalent(a, b, ec);
  return !ec && eq;
}

}  // namespace

std::string read_input_file(const std::string& path, std::size_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw InputError(path, 0, 0, "cannot open file: " + os_error(errno));
  if (S_ISDIR(st.st_mode)) throw InputError(path, 0, 0, "is a directory, not a file");
  if (!S_ISREG(st.st_mode))
    throw InputError(path, 0, 0, "is not a regular file (a device, FIFO or socket); inputs are read from files");
  if (std::size_t(st.st_size) > max_bytes)
    throw InputError(path, 0, 0, "is " + mib(std::size_t(st.st_size)) + ", above the input limit of " + mib(max_bytes));
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path, 0, 0, "cannot open file: " + os_error(errno));
  std::string text;
  text.reserve(std::size_t(st.st_size));
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      throw InputError(path, 0, 0, "read error: " + os_error(err));
    }
    if (n == 0) break;
    text.append(buf, std::size_t(n));
    if (text.size() > max_bytes) {  // grew while being read
      ::close(fd);
      throw InputError(path, 0, 0, "grew above the input limit of " + mib(max_bytes) + " while being read");
    }
  }
  ::close(fd);
  return text;
}

OutputFiles::OutputFiles(std::vector<std::string> inputs) {
  for (std::string& in : inputs)
    if (!in.empty()) inputs_.push_back(std::move(in));
}

void check_outputs(const std::vector<std::string>& outputs, const std::vector<std::string>& inputs) {
  for (std::size_t k = 0; k < outputs.size(); ++k) {
    const std::string& path = outputs[k];
    if (path.empty()) throw InputError("an output path is empty");
    for (const std::string& in : inputs)
      if (!in.empty() && same_file(path, in))
        throw InputError(path, 0, 0,
                         "is also an input of this command (" + in + "); writing it would destroy the input: choose "
                         "another output path");
    for (std::size_t j = 0; j < k; ++j)
      if (same_file(path, outputs[j])) throw InputError(path, 0, 0, "is given as two outputs of this command");
  }
}

void OutputFiles::add(const std::string& path, std::string text) {
  std::vector<std::string> paths;
  for (const Output& o : outputs_) paths.push_back(o.path);
  paths.push_back(path);
  check_outputs(paths, inputs_);
  outputs_.push_back({path, std::move(text)});
}

void OutputFiles::commit() {
  struct Staged {
    const Output* out;
    std::string temp;  // empty: written directly (not a regular file)
  };
  std::vector<Staged> staged;
  auto remove_temps = [&] {
    for (const Staged& s : staged)
      if (!s.temp.empty()) ::unlink(s.temp.c_str());
  };
  try {
    // Regular targets and new files: complete temporaries first.
    for (const Output& o : outputs_) {
      struct stat st {};
      const bool exists = ::stat(o.path.c_str(), &st) == 0;
      if (exists && S_ISDIR(st.st_mode)) throw InputError(o.path, 0, 0, "is a directory; cannot write it");
      if (exists && !S_ISREG(st.st_mode)) {
        staged.push_back({&o, {}});
        continue;
      }
      const fs::path target(o.path);
      const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
      std::string temp;
      int fd = -1;
      for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
        temp = (dir / ("." + target.filename().string() + ".kincal-" + std::to_string(::getpid()) + "-" +
                       std::to_string(attempt)))
                   .string();
        fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd < 0 && errno != EEXIST) break;
      }
      if (fd < 0)
        throw InputError(o.path, 0, 0, "cannot write in " + dir.string() + ": " + os_error(errno));
      staged.push_back({&o, temp});
      write_fd(fd, o.text, o.path, true);
    }
    // Devices and pipes, written directly: a failure there (/dev/full) still
    // leaves every regular target as it was.
    for (const Staged& s : staged) {
      if (!s.temp.empty()) continue;
      const int fd = ::open(s.out->path.c_str(), O_WRONLY | O_CLOEXEC);
      if (fd < 0) throw InputError(s.out->path, 0, 0, "cannot open for writing: " + os_error(errno));
      write_fd(fd, s.out->text, s.out->path, false);
    }
    // Every output is complete: replace the regular targets.
    for (const Staged& s : staged)
      if (!s.temp.empty() && std::rename(s.temp.c_str(), s.out->path.c_str()) != 0)
        throw InputError(s.out->path, 0, 0, "cannot replace the file: " + os_error(errno));
  } catch (...) {
    remove_temps();
    throw;
  }
}

void write_output_file(const std::string& path, const std::string& text, const std::vector<std::string>& inputs) {
  OutputFiles out(inputs);
  out.add(path, text);
  out.commit();
}

}  // namespace kincal::identify
