// Files the tool reads and writes (issue #10 items 5–7): a command must never
// destroy its own input, leave a cut or half-written output, or hang on what
// it was given.
//
// Inputs are regular files of at most kMaxInputBytes, read whole. A
// directory, a device, a FIFO or /dev/zero is refused by name before any
// byte is read (a FIFO would block, /dev/zero never ends).
//
// Outputs go through OutputFiles: every output of a command is staged, then
// written together by commit():
//   - an output that is one of the command's inputs (the same path, or the
//     same file by another name: ./x, a symlink, a hard link) is refused
//     before anything is written;
//   - a regular target (or a new file) is written to a temporary file in its
//     own directory, flushed to disk and checked; only when every output is
//     complete are the temporaries renamed over their targets (rename is
//     atomic in one directory), so any failure — a full disk, an unwritable
//     directory, the second of two files — leaves every old file intact;
//   - a target that exists and is not a regular file (/dev/stdout, a FIFO,
//     /dev/full) cannot be replaced: it is written directly, after the
//     regular ones' temporaries are complete and before they replace their
//     targets, and checked (so /dev/full fails with every regular target
//     intact, and /dev/stdout works).
// Outputs are never read.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace kincal::identify {

// 256 MiB: a laser-tracker campaign of 10^6 rows is ~150 MB of CSV.
inline constexpr std::size_t kMaxInputBytes = std::size_t(256) << 20;

// Reads a whole regular file; throws InputError naming the file if it is
// missing, not a regular file, larger than `max_bytes`, or cannot be read.
std::string read_input_file(const std::string& path, std::size_t max_bytes = kMaxInputBytes);

class OutputFiles {
 public:
  // The paths the command reads (empty entries are ignored).
  explicit OutputFiles(std::vector<std::string> inputs = {});
  // Stages `text` for `path`; nothing is written yet. Throws InputError for an
  // empty path, a path that is one of the inputs, or one staged twice.
  void add(const std::string& path, std::string text);
  // Writes every staged output (see the file comment). Throws InputError
  // naming the file that failed; then no regular target has changed.
  void commit();

 private:
  struct Output {
    std::string path, text;
  };
  std::vector<std::string> inputs_;
  std::vector<Output> outputs_;
};

// Refuses (InputError) an output list with an empty path, a path that is one
// of the inputs, or a path given twice — before a command does any work.
void check_outputs(const std::vector<std::string>& outputs, const std::vector<std::string>& inputs);

// One output: OutputFiles(inputs).add(path, text) and commit().
void write_output_file(const std::string& path, const std::string& text, const std::vector<std::string>& inputs = {});

}  // namespace kincal::identify
