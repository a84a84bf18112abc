// All-or-nothing file output: a writer either replaces the target completely or leaves it
// (and the directory) exactly as it was. Readers therefore never see half-written meshes,
// even when the writer throws, the disk fills up or the process is killed. A program that
// calls remove_temporary_files_on_signals() also leaves no temporary file behind when
// SIGINT or SIGTERM ends it mid-write.
#pragma once

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <signal.h>
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

/// The temporary files being written, where a signal handler can read them: fixed slots,
/// no allocation, no locks (lock-free atomics and unlink() are async-signal-safe).
struct pending_temp_files {
    static constexpr int slots = 8;
    static constexpr std::size_t path_max = 4096;
    std::atomic<int> state[slots] = {}; // 0 free, 1 being filled, 2 holds a path
    char path[slots][path_max] = {};
};
inline pending_temp_files pending_temps;

/// Registers a temporary file for the signal handler; -1 if no slot (or too long a path):
/// that file is then only removed on the ordinary error paths.
inline int register_temp(const char* path) noexcept {
    const std::size_t n = std::strlen(path);
    if (n >= pending_temp_files::path_max) return -1;
    for (int i = 0; i < pending_temp_files::slots; ++i) {
        int expected = 0;
        if (pending_temps.state[i].compare_exchange_strong(expected, 1)) {
            std::memcpy(pending_temps.path[i], path, n + 1);
            pending_temps.state[i].store(2);
            return i;
        }
    }
    return -1;
}

inline void unregister_temp(int slot) noexcept {
    if (slot >= 0) pending_temps.state[slot].store(0);
}

inline void remove_temps_and_reraise(int sig) {
    const int saved = errno;
    for (int i = 0; i < pending_temp_files::slots; ++i)
        if (pending_temps.state[i].load() == 2) ::unlink(pending_temps.path[i]);
    errno = saved;
    // The default action (termination by `sig`) once this handler returns, so the parent
    // sees the usual exit status.
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

/// Blocks SIGINT and SIGTERM in this thread while alive: between creating the temporary
/// file and registering it, a signal would leave it behind.
class signal_block {
public:
    signal_block() noexcept {
        sigset_t set;
        sigemptyset(&set);
        sigaddset(&set, SIGINT);
        sigaddset(&set, SIGTERM);
        pthread_sigmask(SIG_BLOCK, &set, &old_);
    }
    signal_block(const signal_block&) = delete;
    signal_block& operator=(const signal_block&) = delete;
    ~signal_block() { pthread_sigmask(SIG_SETMASK, &old_, nullptr); }

private:
    sigset_t old_;
};

/// Removes the temporary file unless released: the cleanup runs on every error path.
/// Holds its signal-handler registration, dropped only after the file is gone or renamed
/// (a handler running in between unlinks a missing name, which is harmless).
class temp_file_guard {
public:
    temp_file_guard(std::filesystem::path p, int slot)
        : path_(std::move(p))
        , slot_(slot) {}
    temp_file_guard(const temp_file_guard&) = delete;
    temp_file_guard& operator=(const temp_file_guard&) = delete;
    ~temp_file_guard() {
        if (!path_.empty()) {
            std::error_code ignored;
            std::filesystem::remove(path_, ignored);
        }
        unregister_temp(slot_);
    }
    void release() noexcept { path_.clear(); }

private:
    std::filesystem::path path_;
    int slot_;
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

    int fd_value = -1, slot = -1, err = 0;
    {
        const detail::signal_block blocked;
        fd_value = ::mkstemp(name.data());
        err = errno;
        if (fd_value >= 0) slot = detail::register_temp(name.data());
    }
    const detail::fd_guard fd(fd_value);
    if (fd.get() < 0) detail::throw_write_error(target, err, "cannot create temporary file");
    const fs::path temp(name.data());
    detail::temp_file_guard cleanup(temp, slot);

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

/// Installs handlers for SIGINT and SIGTERM that remove the temporary files of writes in
/// progress, then end the process by the same signal. Signals the process ignores stay
/// ignored. For programs (the idas tool); a library never installs handlers by itself.
inline void remove_temporary_files_on_signals() {
    for (const int sig : {SIGINT, SIGTERM}) {
        struct sigaction current {};
        if (::sigaction(sig, nullptr, &current) != 0 || current.sa_handler == SIG_IGN) continue;
        struct sigaction action {};
        action.sa_handler = detail::remove_temps_and_reraise;
        sigemptyset(&action.sa_mask);
        ::sigaction(sig, &action, nullptr);
    }
}

} // namespace idas::io
