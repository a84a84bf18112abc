// Format-independent entry points: pick the reader or writer from the file extension.
#pragma once

#include "idas/io/obj.hpp"
#include "idas/io/off.hpp"
#include "idas/io/ply.hpp"
#include "idas/io/stl.hpp"
#include "idas/io/surface.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace idas::io {

struct format_options {
    /// Encoding for PLY and STL; OBJ and OFF are always text.
    io::encoding encoding = io::encoding::binary;
};

enum class file_format { obj, off, ply, stl };

/// The format named by the extension of `path` (case-insensitive); input_error otherwise.
inline file_format format_of(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    for (char& c : ext)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (ext == ".obj") return file_format::obj;
    if (ext == ".off") return file_format::off;
    if (ext == ".ply") return file_format::ply;
    if (ext == ".stl") return file_format::stl;
    detail::fail(path.string(), "unknown mesh file extension " + detail::quoted(ext) +
                                    " (expected .obj, .off, .ply or .stl)");
}

/// Reads a triangle surface; every problem with the file is an input_error whose message
/// starts with the path.
inline surface read_surface(const std::filesystem::path& path, const read_options& options = {}) {
    switch (format_of(path)) {
    case file_format::obj:
        return read_obj(path, options);
    case file_format::off:
        return read_off(path, options);
    case file_format::ply:
        return read_ply(path, options);
    case file_format::stl:
        return read_stl(path, options);
    }
    return {};
}

/// The attributes of `s` that writing it to `path` would lose, as "name (domain)": the
/// callers warn about them (see each format's *_unstored_attributes).
inline std::vector<std::string> unstored_attributes(const std::filesystem::path& path,
                                                    const surface& s,
                                                    const format_options& options = {}) {
    switch (format_of(path)) {
    case file_format::obj:
        return obj_unstored_attributes(s);
    case file_format::off:
        return off_unstored_attributes(s);
    case file_format::ply:
        return ply_unstored_attributes(s);
    case file_format::stl:
        return stl_unstored_attributes(s, options.encoding);
    }
    return {};
}

/// Writes a triangle surface atomically: the target is either fully replaced or untouched.
/// An invalid surface or unknown extension raises input_error; operating-system failures
/// raise std::system_error.
inline void write_surface(const std::filesystem::path& path, const surface& s,
                          const format_options& options = {}) {
    switch (format_of(path)) {
    case file_format::obj:
        write_obj(path, s);
        return;
    case file_format::off:
        write_off(path, s);
        return;
    case file_format::ply:
        write_ply(path, s, options.encoding);
        return;
    case file_format::stl:
        write_stl(path, s, options.encoding);
        return;
    }
}

} // namespace idas::io
