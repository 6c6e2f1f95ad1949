#include <plx/core/file.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

namespace plx {
namespace {

// The cause of a failed open in words a user can act on.
Status openError(const std::string& path, int err) {
    switch (err) {
        case ENOENT:
            return errorStatus(ErrorCode::kNotFound, fmt::format("'{}': file not found", path));
        case ENOTDIR:
            return errorStatus(
                ErrorCode::kNotFound,
                fmt::format("'{}': a component of the path is not a directory", path));
        case ELOOP:
            return errorStatus(ErrorCode::kIoError,
                               fmt::format("'{}': too many levels of symbolic links (a symlink "
                                           "loop)",
                                           path));
        case EACCES:
        case EPERM:
            return errorStatus(ErrorCode::kIoError, fmt::format("'{}': permission denied", path));
        case EISDIR:
            return errorStatus(ErrorCode::kIoError,
                               fmt::format("'{}' is a directory, not a file", path));
        default:
            return errorStatus(ErrorCode::kIoError,
                               fmt::format("'{}': cannot open: {}", path, std::strerror(err)));
    }
}

const char* fileKind(mode_t mode) {
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return "not a regular file";
}

// Closes the descriptor on every path out.
struct Fd {
    int fd = -1;
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
};

// Opens path for reading and checks that it is a regular file; gives its size.
Status openRegular(const std::string& path, Fd* file, uint64_t* size) {
    // O_NONBLOCK: opening a FIFO with no writer would otherwise wait forever; the check below
    // then refuses it.
    file->fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (file->fd < 0) return openError(path, errno);
    struct stat st {};
    if (::fstat(file->fd, &st) != 0) return openError(path, errno);
    if (!S_ISREG(st.st_mode))
        return errorStatus(ErrorCode::kIoError, fmt::format("'{}' is {}, not a regular file", path,
                                                            fileKind(st.st_mode)));
    *size = uint64_t(st.st_size);
    return Status::ok();
}

}  // namespace

Result<uint64_t> checkRegularFile(const std::string& path) {
    Fd file;
    uint64_t size = 0;
    PLX_RETURN_IF_ERROR(openRegular(path, &file, &size));
    return size;
}

Result<std::string> readFileChecked(const std::string& path, uint64_t maxBytes) {
    Fd file;
    uint64_t size = 0;
    PLX_RETURN_IF_ERROR(openRegular(path, &file, &size));
    if (size > maxBytes)
        return errorStatus(
            ErrorCode::kOutOfRange,
            fmt::format("'{}' holds {} bytes, more than the limit of {}", path, size, maxBytes));
    std::string bytes(size_t(size), '\0');
    size_t done = 0;
    while (done < bytes.size()) {
        ssize_t got = ::read(file.fd, bytes.data() + done, bytes.size() - done);
        if (got < 0 && errno == EINTR) continue;
        if (got < 0)
            return errorStatus(ErrorCode::kIoError,
                               fmt::format("'{}': read failed: {}", path, std::strerror(errno)));
        if (got == 0) break;  // the file shrank while being read: keep what is there
        done += size_t(got);
    }
    bytes.resize(done);
    return bytes;
}

std::string lineColumn(std::string_view text, size_t byteOffset) {
    byteOffset = std::min(byteOffset, text.size());
    size_t line = 1, lineStart = 0;
    for (size_t i = 0; i < byteOffset; ++i)
        if (text[i] == '\n') {
            ++line;
            lineStart = i + 1;
        }
    return fmt::format("line {}, column {}", line, byteOffset - lineStart + 1);
}

}  // namespace plx
