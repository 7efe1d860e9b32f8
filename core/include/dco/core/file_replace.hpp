#pragma once

#include <filesystem>
#include <functional>

namespace dco {

// Writes a file beside its name and renames it over that name: a reader never sees half a file,
// and a failed write (a full disk, a quota) leaves no file behind, or the earlier one whole.
// `write` fills the temporary path it is given, whose name ends like `path` (OpenCV picks the
// format by the extension); an exception from it removes the temporary file and goes on. Throws
// dco::Error when the rename fails. A symbolic link is written through (the file it names is
// replaced, the link stays), and a FIFO or device (/dev/stdout) is written in place, from a
// temporary file in the system's temporary directory.
void replace_file(const std::filesystem::path& path,
                  const std::function<void(const std::filesystem::path& tmp)>& write);

}  // namespace dco
