#pragma once
// Files appear whole or not at all: written under a temporary name in the same directory, then renamed.
#include <functional>
#include <string>

namespace mpm {

/// Calls write(tmpPath), then renames tmpPath to path. On any exception the temporary file is removed
/// and the exception propagates; an existing file at path stays as it was.
void writeAtomically(const std::string& path, const std::function<void(const std::string& tmpPath)>& write);

/// Convenience: the whole text content at once.
void writeTextAtomically(const std::string& path, const std::string& text);

}  // namespace mpm
