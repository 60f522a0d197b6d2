#include "io/AtomicFile.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <streambuf>

namespace mpm {

namespace {
constexpr std::size_t kBufferBytes = 1 << 16;
constexpr mode_t kFileMode = 0644;

std::string reasonOf(int error) { return std::strerror(error); }

/// Writes all of [data, data + n) to fd; returns 0 or the errno of the write that failed.
int writeAll(int fd, const char* data, std::size_t n) {
    while (n > 0) {
        const ssize_t w = ::write(fd, data, n);
        if (w < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        if (w == 0) return EIO;  // a write that moves nothing would loop forever
        data += w;
        n -= std::size_t(w);
    }
    return 0;
}
}  // namespace

/// A stream buffer over a file descriptor that remembers the first failed write's errno.
class AtomicFile::Buffer : public std::streambuf {
public:
    explicit Buffer(int fd) : fd_(fd), data_(kBufferBytes) { setp(data_.data(), data_.data() + data_.size()); }
    int error() const { return error_; }
    /// Writes what is buffered; false once any write failed.
    bool drain() {
        const std::size_t n = std::size_t(pptr() - pbase());
        if (error_ == 0 && n > 0) error_ = writeAll(fd_, pbase(), n);
        if (error_ == 0) written_ += std::streamoff(n);
        setp(data_.data(), data_.data() + data_.size());
        return error_ == 0;
    }

protected:
    int_type overflow(int_type c) override {
        if (!drain()) return traits_type::eof();
        if (!traits_type::eq_int_type(c, traits_type::eof())) {
            *pptr() = traits_type::to_char_type(c);
            pbump(1);
        }
        return traits_type::not_eof(c);
    }
    int sync() override { return drain() ? 0 : -1; }
    std::streamsize xsputn(const char* s, std::streamsize n) override {
        if (n >= std::streamsize(data_.size())) {  // large blocks go straight to the file
            if (!drain()) return 0;
            error_ = writeAll(fd_, s, std::size_t(n));
            if (error_ != 0) return 0;
            written_ += n;
            return n;
        }
        return std::streambuf::xsputn(s, n);
    }
    pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
        if (off != 0 || dir != std::ios_base::cur) return pos_type(off_type(-1));  // tellp only
        return pos_type(written_ + (pptr() - pbase()));
    }

private:
    int fd_;
    std::vector<char> data_;
    int error_ = 0;
    std::streamoff written_ = 0;
};

std::string temporaryPathOf(const std::string& path) { return path + ".tmp" + std::to_string(::getpid()); }

bool isTemporaryOf(const std::string& name, const std::string& finalName) {
    const std::string prefix = finalName + ".tmp";
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return false;
    for (std::size_t i = prefix.size(); i < name.size(); ++i)
        if (name[i] < '0' || name[i] > '9') return false;
    return true;
}

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)), tmp_(temporaryPathOf(path_)) {
    fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, kFileMode);
    if (fd_ < 0) throw WriteError(path_, "cannot create " + tmp_ + ": " + reasonOf(errno));
    buffer_ = std::make_unique<Buffer>(fd_);
    stream_ = std::make_unique<std::ostream>(buffer_.get());
}

AtomicFile::~AtomicFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_) ::unlink(tmp_.c_str());
}

std::ostream& AtomicFile::stream() { return *stream_; }

void AtomicFile::failWith(int error) {
    ::close(fd_);
    fd_ = -1;
    ::unlink(tmp_.c_str());
    throw WriteError(path_, reasonOf(error));
}

void AtomicFile::commit() {
    stream_->flush();
    if (!buffer_->drain() || !*stream_) failWith(buffer_->error() ? buffer_->error() : EIO);
    // The data reaches the disk before the name does: a crash after the rename must not leave an empty file.
    if (::fsync(fd_) != 0) failWith(errno);
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) {
        const int e = errno;
        ::unlink(tmp_.c_str());
        throw WriteError(path_, reasonOf(e));
    }
    if (::rename(tmp_.c_str(), path_.c_str()) != 0) {
        const int e = errno;
        ::unlink(tmp_.c_str());
        throw WriteError(path_, "cannot rename " + tmp_ + " into place: " + reasonOf(e));
    }
    committed_ = true;
    // And the rename itself survives a crash once the directory is synced.
    const std::string dir = std::filesystem::path(path_).parent_path().string();
    const int d = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (d >= 0) {
        ::fsync(d);
        ::close(d);
    }
}

void writeAtomically(const std::string& path, const std::function<void(std::ostream&)>& write) {
    AtomicFile file(path);
    write(file.stream());
    file.commit();
}

void writeTextAtomically(const std::string& path, const std::string& text) {
    writeAtomically(path, [&](std::ostream& out) { out.write(text.data(), std::streamsize(text.size())); });
}

}  // namespace mpm
