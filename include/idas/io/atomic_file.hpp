// All-or-nothing file output: a writer either replaces the target completely or leaves it
// (and the directory) exactly as it was. Readers therefore never see half-written meshes,
// even when the writer throws, the disk fills up or the process is killed.
#pragma once

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace idas::io {

namespace detail {

[[noreturn]] inline void throw_write_error(const std::filesystem::path& target, int err,
                                           const std::string& what) {
    throw std::system_error(err, std::generic_category(), target.string() + ": " + what);
}

/// The process umask, read without changing it (umask(2) can only read by setting, which
/// would race with other threads creating files). Linux exposes it in /proc.
inline mode_t current_umask() {
    std::ifstream status("/proc/self/status");
    std::string key;
    while (status >> key) {
        if (key == "Umask:") {
            std::string value;
            status >> value;
            return static_cast<mode_t>(std::strtoul(value.c_str(), nullptr, 8));
        }
    }
    return 022;
}

/// Removes the temporary file unless released: the cleanup runs on every error path.
class temp_file_guard {
public:
    explicit temp_file_guard(std::filesystem::path p)
        : path_(std::move(p)) {}
    temp_file_guard(const temp_file_guard&) = delete;
    temp_file_guard& operator=(const temp_file_guard&) = delete;
    ~temp_file_guard() {
        if (!path_.empty()) {
            std::error_code ignored;
            std::filesystem::remove(path_, ignored);
        }
    }
    void release() noexcept { path_.clear(); }

private:
    std::filesystem::path path_;
};

/// Closes a POSIX descriptor on scope exit.
class fd_guard {
public:
    explicit fd_guard(int fd) noexcept
        : fd_(fd) {}
    fd_guard(const fd_guard&) = delete;
    fd_guard& operator=(const fd_guard&) = delete;
    ~fd_guard() {
        if (fd_ >= 0) ::close(fd_);
    }
    int get() const noexcept { return fd_; }

private:
    int fd_;
};

} // namespace detail

/// Calls `write_to_ostream(std::ostream&)` on a fresh temporary file next to `target`
/// (named "<target>.tmp.XXXXXX", so the final rename stays within one file system and is
/// atomic), syncs it, and renames it over `target`. If anything fails, including an
/// exception from the callback, the temporary file is removed and the exception propagates;
/// operating-system failures are reported as std::system_error naming the target.
template <class F>
void write_atomically(const std::filesystem::path& target, F&& write_to_ostream) {
    namespace fs = std::filesystem;
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    std::string pattern = (dir / target.filename()).string() + ".tmp.XXXXXX";
    std::vector<char> name(pattern.begin(), pattern.end());
    name.push_back('\0');

    const detail::fd_guard fd(::mkstemp(name.data()));
    if (fd.get() < 0) detail::throw_write_error(target, errno, "cannot create temporary file");
    const fs::path temp(name.data());
    detail::temp_file_guard cleanup(temp);

    // mkstemp creates the file private (0600); give it the permissions a plain create
    // would have produced, or keep those of the file being replaced.
    struct stat existing {};
    const mode_t mode = (::stat(target.c_str(), &existing) == 0)
                            ? (existing.st_mode & 07777)
                            : (0666 & ~detail::current_umask());
    if (::fchmod(fd.get(), mode) != 0)
        detail::throw_write_error(target, errno, "cannot set permissions of temporary file");

    {
        errno = 0; // so a stream failure below reports the system's reason, if it set one
        std::ofstream out(temp, std::ios::binary | std::ios::trunc);
        if (!out) detail::throw_write_error(target, errno, "cannot open temporary file");
        std::forward<F>(write_to_ostream)(static_cast<std::ostream&>(out));
        out.flush();
        if (!out) detail::throw_write_error(target, errno ? errno : EIO, "write failed");
        out.close();
        if (!out) detail::throw_write_error(target, errno ? errno : EIO, "write failed");
    }
    // Data must be on disk before the rename makes it visible, or a crash could leave an
    // empty file under the target name.
    if (::fsync(fd.get()) != 0) detail::throw_write_error(target, errno, "fsync failed");

    std::error_code ec;
    fs::rename(temp, target, ec);
    if (ec) detail::throw_write_error(target, ec.value(), "cannot rename temporary file");
    cleanup.release();
}

} // namespace idas::io
