// src/golden/golden_internal.h — what the golden room's files share and nobody else needs.
#pragma once

#include <streambuf>
#include <string>
#include <string_view>

#include <glm/glm.hpp>

#include "tessref/error.h"

namespace tessref::golden {

// The SHA-256 of `bytes` in 64 lower-case hex digits (OpenSSL).
std::string sha256_hex(std::string_view bytes);

// A SHA-256 fed piece by piece (OpenSSL's EVP interface).
class Sha256 {
public:
    Sha256();
    ~Sha256();
    Sha256(const Sha256&) = delete;
    Sha256& operator=(const Sha256&) = delete;
    void add(std::string_view bytes);
    std::string hex();  // once, after the last piece

private:
    void* context_;  // EVP_MD_CTX
};

// An output stream's buffer that digests what is written to it instead of keeping it: the
// mesh's PLY is hashed as write_mesh() writes it, never held.
class Sha256Buffer : public std::streambuf {
public:
    Sha256Buffer() { setp(buffer_, buffer_ + sizeof buffer_); }
    std::size_t bytes() const { return bytes_ + static_cast<std::size_t>(pptr() - pbase()); }
    std::string hex() {
        flush();
        return sha_.hex();
    }

protected:
    int_type overflow(int_type c) override {
        flush();
        if (!traits_type::eq_int_type(c, traits_type::eof())) {
            *pptr() = traits_type::to_char_type(c);
            pbump(1);
        }
        return traits_type::not_eof(c);
    }
    std::streamsize xsputn(const char* s, std::streamsize n) override {
        if (n <= epptr() - pptr()) {  // small writes gather in the buffer
            traits_type::copy(pptr(), s, static_cast<std::size_t>(n));
            pbump(static_cast<int>(n));
            return n;
        }
        flush();
        sha_.add(std::string_view(s, static_cast<std::size_t>(n)));
        bytes_ += static_cast<std::size_t>(n);
        return n;
    }
    int sync() override {
        flush();
        return 0;
    }

private:
    void flush() {
        const std::size_t n = static_cast<std::size_t>(pptr() - pbase());
        sha_.add(std::string_view(pbase(), n));
        bytes_ += n;
        setp(buffer_, buffer_ + sizeof buffer_);
    }
    Sha256 sha_;
    std::size_t bytes_ = 0;
    char buffer_[1 << 14];
};

// "WxH" (1..16384 each) as `size` lines and `--size` write it; an Error at `where` otherwise.
glm::ivec2 parse_size(const std::string& text, const Where& where);

}  // namespace tessref::golden
