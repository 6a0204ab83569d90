// src/image/deflate.h — a fast deflate (RFC 1951) encoder for the PNG writer's bands
// (private to src/image/).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace tessref::image::detail {

// The raw deflate data of data[0, size), ending on a byte boundary. With `last`, the final
// block carries BFINAL and the stream is complete; without it the data ends as zlib's
// Z_SYNC_FLUSH ends it (an empty stored block where the blocks would not end on a byte), so
// that the next band's deflate data can follow it in the same stream. A band refers to no
// byte before its own: each band is compressed alone, on any thread.
//
// Greedy LZ77 (one candidate a position, the last position with the same hash of its 4
// bytes; matches of 4 to 258 bytes within 32 KiB, the positions inside a match not
// hashed) and one dynamic-Huffman block, or stored blocks where those would be larger. A
// rendered image's filtered rows come out 3 to 5 % larger than zlib's level 1 makes them,
// in a third of the time.
std::vector<std::uint8_t> deflate_band(const std::uint8_t* data, std::size_t size, bool last);

}  // namespace tessref::image::detail
