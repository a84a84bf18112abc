// The progress bar of `idas decimate`, `remesh` and `harmonic`: drawn on stderr when it is
// a terminal (never on a pipe or file), once the run has lasted a second, at most ten
// times a second, by whichever thread gets there first. Included by idas_cli.cpp inside
// its anonymous namespace. IDAS_PROGRESS_DELAY_MS overrides the one-second delay (tests).
#pragma once

class terminal_progress {
public:
    explicit terminal_progress(const char* label)
        : label_(label)
        , enabled_(isatty(fileno(stderr)) != 0) {
        if (const char* d = std::getenv("IDAS_PROGRESS_DELAY_MS")) {
            char* end = nullptr;
            const long ms = std::strtol(d, &end, 10);
            if (end != d && ms >= 0) next_draw_ms_ = ms;
        }
    }
    terminal_progress(const terminal_progress&) = delete;
    terminal_progress& operator=(const terminal_progress&) = delete;
    ~terminal_progress() { end_line(); }

    bool enabled() const noexcept { return enabled_; }

    /// Draws `done` (0 to 1) and a note, if a redraw is due.
    void draw(double done, const std::string& note) {
        if (!enabled_) return;
        const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                            std::chrono::steady_clock::now() - started_)
                            .count();
        std::int64_t due = next_draw_ms_.load(std::memory_order_relaxed);
        if (ms < due || !next_draw_ms_.compare_exchange_strong(due, ms + 100)) return;
        done = std::clamp(done, 0.0, 1.0);
        const int width = 40, filled = static_cast<int>(done * width);
        std::fprintf(stderr, "\r%s [%s%s] %3.0f%%  %s\x1b[K", label_,
                     std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(),
                     100 * done, note.c_str());
        drawn_ = true;
    }
    /// Ends the bar's line, if one was drawn.
    void end_line() {
        if (drawn_.exchange(false)) std::fprintf(stderr, "\n");
    }

private:
    const char* label_;
    bool enabled_;
    std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
    std::atomic<std::int64_t> next_draw_ms_{1000};
    std::atomic<bool> drawn_{false};
};
