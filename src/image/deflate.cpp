// The PNG writer's deflate encoder (deflate.h). zlib's level 1 spent about 10 % of a
// 1280 x 800 render's CPU compressing its 4 MB of filtered rows, in its general-purpose
// hash chains, window sliding and 16-bit bit buffer; this encoder does the one thing the
// writer needs: a band of filtered rows in memory, compressed in one pass.
#include "image/deflate.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <memory>

namespace tessref::image::detail {

namespace {

// ---- the format's tables (RFC 1951, section 3.2.5) ---------------------------------------

constexpr int kLengthCodes = 29, kDistanceCodes = 30;
constexpr std::uint16_t kLengthBase[kLengthCodes] = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                                     31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
constexpr std::uint8_t kLengthExtra[kLengthCodes] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                                     2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
constexpr std::uint16_t kDistanceBase[kDistanceCodes] = {1,    2,    3,    4,    5,    7,     9,     13,    17,  25,
                                                         33,   49,   65,   97,   129,  193,   257,   385,   513, 769,
                                                         1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
constexpr std::uint8_t kDistanceExtra[kDistanceCodes] = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,  4,  4,  5,  5,  6,
                                                         6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};
// The order in which the code-length code's lengths are sent.
constexpr std::uint8_t kCodeLengthOrder[19] = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};

constexpr int kLiterals = 286, kEndOfBlock = 256, kCodeLengthSymbols = 19;
constexpr int kMinMatch = 4, kMaxMatch = 258;
constexpr std::size_t kWindow = 32768;

// The code of each match length (length - 3) and of each distance (distance - 1 below 256,
// else 256 + ((distance - 1) >> 7)), as zlib's trees.c tabulates them.
struct CodeTables {
    std::array<std::uint8_t, 256> length_code{};
    std::array<std::uint8_t, 512> distance_code{};
    CodeTables() {
        for (int c = 0; c < kLengthCodes - 1; ++c)
            for (int k = 0; k < (1 << kLengthExtra[c]); ++k) length_code[kLengthBase[c] - 3 + k] = static_cast<std::uint8_t>(c);
        length_code[255] = kLengthCodes - 1;  // 258 has a code of its own, not 227 + 31
        for (int c = 0; c < kDistanceCodes; ++c)
            for (int k = 0; k < (1 << kDistanceExtra[c]); ++k) {
                const int d = kDistanceBase[c] - 1 + k;
                if (d < 256) distance_code[d] = static_cast<std::uint8_t>(c);
                else distance_code[256 + (d >> 7)] = static_cast<std::uint8_t>(c);
            }
    }
    int distance(std::uint32_t d_minus_1) const {
        return d_minus_1 < 256 ? distance_code[d_minus_1] : distance_code[256 + (d_minus_1 >> 7)];
    }
};
const CodeTables& tables() {
    static const CodeTables t;
    return t;
}

// ---- Huffman codes ------------------------------------------------------------------------

// Lengths of a Huffman code for freq[0, n), none longer than `limit`; symbols of frequency 0
// get length 0. A code of fewer than two symbols gets a second symbol, so that the code is
// complete (inflate refuses an incomplete code of more than one length-1 symbol).
void code_lengths(const std::uint32_t* freq, int n, int limit, std::uint8_t* lengths) {
    std::array<int, kLiterals> used{};
    int count = 0;
    for (int s = 0; s < n; ++s)
        if (freq[s] != 0) used[count++] = s;
    std::fill(lengths, lengths + n, std::uint8_t{0});
    if (count < 2) {  // symbols 0 and 1, or the one used and 0 or 1 beside it
        const int one = count == 1 ? used[0] : 0;
        lengths[one] = 1;
        lengths[one == 0 ? 1 : 0] = 1;
        return;
    }
    // Leaves by increasing frequency; the internal nodes are made in increasing weight
    // order, so two queues give the two smallest at each step (van Leeuwen's method).
    std::stable_sort(used.begin(), used.begin() + count, [&](int a, int b) { return freq[a] < freq[b]; });
    std::array<std::uint64_t, kLiterals> weight{};
    std::array<int, 2 * kLiterals> parent{};  // leaves 0..count-1 (by rank), then internal nodes
    int leaf = 0, inner = 0;
    const auto take = [&](int made) {
        if (leaf < count && (inner >= made || freq[used[leaf]] <= weight[inner])) return leaf++;
        return count + inner++;
    };
    for (int made = 0; made < count - 1; ++made) {
        const int a = take(made), b = take(made);
        const auto w = [&](int node) { return node < count ? std::uint64_t{freq[used[node]]} : weight[node - count]; };
        weight[made] = w(a) + w(b);
        parent[a] = parent[b] = count + made;
    }
    // Depths from the root (the last internal node) down; the leaves' depths counted by length.
    std::array<int, 2 * kLiterals> depth{};
    std::array<int, 64> per_length{};
    depth[2 * count - 2] = 0;
    for (int node = 2 * count - 3; node >= 0; --node) {
        depth[node] = depth[parent[node]] + 1;
        if (node < count) ++per_length[std::min(depth[node], 63)];
    }
    // Too long: fold the lengths above the limit into it, then restore Kraft's equality
    // (the sum of 2^-length over the codes is 1) one unit of 2^-limit at a time: a code at
    // the limit is taken away and the deepest shorter code split into two one bit longer,
    // which keeps the number of codes.
    for (int l = limit + 1; l < 64; ++l) {
        per_length[limit] += per_length[l];
        per_length[l] = 0;
    }
    std::uint64_t kraft = 0;
    for (int l = 1; l <= limit; ++l) kraft += std::uint64_t(per_length[l]) << (limit - l);
    while (kraft > (std::uint64_t{1} << limit)) {
        --per_length[limit];
        for (int l = limit - 1; l > 0; --l)
            if (per_length[l] != 0) {
                --per_length[l];
                per_length[l + 1] += 2;
                break;
            }
        --kraft;
    }
    // The longest codes to the rarest symbols.
    int rank = 0;
    for (int l = limit; l >= 1; --l)
        for (int k = 0; k < per_length[l]; ++k) lengths[used[rank++]] = static_cast<std::uint8_t>(l);
}

// The canonical codes of `lengths` (RFC 1951, 3.2.2), bit-reversed: deflate sends a Huffman
// code from its most significant bit, into a stream filled from each byte's least.
void canonical_codes(const std::uint8_t* lengths, int n, std::uint16_t* codes) {
    std::array<int, 16> per_length{};
    for (int s = 0; s < n; ++s) ++per_length[lengths[s]];
    per_length[0] = 0;
    std::array<int, 16> next{};
    for (int l = 1, code = 0; l < 16; ++l) {
        code = (code + per_length[l - 1]) << 1;
        next[l] = code;
    }
    for (int s = 0; s < n; ++s) {
        const int l = lengths[s];
        if (l == 0) continue;
        unsigned c = static_cast<unsigned>(next[l]++), reversed = 0;
        for (int b = 0; b < l; ++b, c >>= 1) reversed = (reversed << 1) | (c & 1u);
        codes[s] = static_cast<std::uint16_t>(reversed);
    }
}

// ---- output ---------------------------------------------------------------------------------

// Bits into bytes, least significant first; `out` is sized beforehand (4 bytes of slack).
struct BitWriter {
    std::uint8_t* out;
    std::uint64_t bits = 0;
    int count = 0;
    void put(std::uint32_t value, int n) {  // n <= 32
        bits |= std::uint64_t{value} << count;
        count += n;
        if (count >= 32) {
            const auto word = static_cast<std::uint32_t>(bits);
            std::memcpy(out, &word, 4);  // little endian, as the stream is
            out += 4;
            bits >>= 32;
            count -= 32;
        }
    }
    void align() {
        for (; count > 0; count -= 8, bits >>= 8) *out++ = static_cast<std::uint8_t>(bits);
        count = 0;
        bits = 0;
    }
};

// A parsed band: runs of literals and matches, in order. A match is kMatch | (length - 3)
// << 15 | (distance - 1); a run of literals is its count, the bytes read from the input.
constexpr std::uint32_t kMatch = 0x80000000u;

std::uint32_t load32(const std::uint8_t* p) {
    std::uint32_t v;
    std::memcpy(&v, p, 4);
    return v;
}
std::uint64_t load64(const std::uint8_t* p) {
    std::uint64_t v;
    std::memcpy(&v, p, 8);
    return v;
}

// Stored blocks (incompressible data): at most 65535 bytes each, byte-aligned throughout.
std::vector<std::uint8_t> stored(const std::uint8_t* data, std::size_t size, bool last) {
    std::vector<std::uint8_t> out;
    out.reserve(size + 5 * (size / 65535 + 1));
    std::size_t at = 0;
    do {
        const std::size_t n = std::min<std::size_t>(65535, size - at);
        out.push_back(last && at + n == size ? 1 : 0);  // BFINAL, BTYPE 00, padding
        const std::uint8_t header[4] = {static_cast<std::uint8_t>(n), static_cast<std::uint8_t>(n >> 8),
                                        static_cast<std::uint8_t>(~n), static_cast<std::uint8_t>(~n >> 8)};
        out.insert(out.end(), header, header + 4);
        out.insert(out.end(), data + at, data + at + n);
        at += n;
    } while (at < size);
    return out;
}

}  // namespace

std::vector<std::uint8_t> deflate_band(const std::uint8_t* data, std::size_t size, bool last) {
    const CodeTables& t = tables();
    // ---- parse: greedy matches from a table of the last position of each 4-byte hash ----
    constexpr int kHashBits = 14;
    std::vector<std::uint32_t> head(std::size_t{1} << kHashBits, 0);
    std::unique_ptr<std::uint32_t[]> items(new std::uint32_t[size / 2 + 2]);  // a run, then a match, at most
    std::size_t item_count = 0;
    std::array<std::uint32_t, kLiterals> literal_freq{};
    std::array<std::uint32_t, kDistanceCodes> distance_freq{};
    std::size_t i = 0, run_start = 0;
    const auto end_run = [&](std::size_t at) {
        if (at > run_start) items[item_count++] = static_cast<std::uint32_t>(at - run_start);
    };
    // How far the bytes at i repeat those at `from` (the first kMinMatch already compared),
    // up to kMaxMatch and the band's end: eight bytes a step, the first difference's byte
    // found from its lowest set bit (the loads are little endian).
    const auto match_length = [&](std::size_t from) {
        const std::size_t limit = std::min<std::size_t>(kMaxMatch, size - i);
        std::size_t length = kMinMatch;
        for (; length + 8 <= limit; length += 8) {
            const std::uint64_t diff = load64(data + i + length) ^ load64(data + from + length);
            if (diff != 0) return length + static_cast<std::size_t>(__builtin_ctzll(diff) >> 3);
        }
        while (length < limit && data[i + length] == data[from + length]) ++length;
        return length;
    };
    while (i + kMinMatch <= size) {
        const std::uint32_t v = load32(data + i);
        const std::uint32_t h = (v * 2654435761u) >> (32 - kHashBits);
        const std::uint32_t candidate = head[h];
        head[h] = static_cast<std::uint32_t>(i);
        if (candidate < i && i - candidate <= kWindow && load32(data + candidate) == v) {
            const std::size_t length = match_length(candidate);
            end_run(i);
            const std::uint32_t distance = static_cast<std::uint32_t>(i - candidate);
            items[item_count++] = kMatch | static_cast<std::uint32_t>(length - 3) << 15 | (distance - 1);
            ++literal_freq[257 + t.length_code[length - 3]];
            ++distance_freq[t.distance(distance - 1)];
            i += length;
            run_start = i;
        } else {
            ++literal_freq[data[i++]];
        }
    }
    for (; i < size; ++i) ++literal_freq[data[i]];
    end_run(size);
    literal_freq[kEndOfBlock] = 1;

    // ---- the codes, and the block's size in bits ----
    std::array<std::uint8_t, kLiterals> literal_length{};
    std::array<std::uint8_t, kDistanceCodes> distance_length{};
    code_lengths(literal_freq.data(), kLiterals, 15, literal_length.data());
    code_lengths(distance_freq.data(), kDistanceCodes, 15, distance_length.data());
    int literal_count = kLiterals, distance_count = kDistanceCodes;
    while (literal_count > 257 && literal_length[literal_count - 1] == 0) --literal_count;
    while (distance_count > 1 && distance_length[distance_count - 1] == 0) --distance_count;
    // Both code lengths in one sequence, run-length coded with the symbols 16 (repeat the
    // previous length 3-6 times), 17 (3-10 zeros) and 18 (11-138 zeros).
    std::array<std::uint8_t, kLiterals + kDistanceCodes> all{};
    std::copy_n(literal_length.begin(), literal_count, all.begin());
    std::copy_n(distance_length.begin(), distance_count, all.begin() + literal_count);
    const int all_count = literal_count + distance_count;
    std::array<std::uint16_t, kLiterals + kDistanceCodes> runs{};  // symbol | extra value << 8
    int run_count = 0;
    std::array<std::uint32_t, kCodeLengthSymbols> length_freq{};
    for (int s = 0; s < all_count;) {
        const std::uint8_t l = all[s];
        int same = 1;
        while (s + same < all_count && all[s + same] == l) ++same;
        s += same;
        if (l == 0) {
            for (; same >= 11; same -= std::min(same, 138)) runs[run_count++] = 18 | (std::min(same, 138) - 11) << 8;
            if (same >= 3) runs[run_count++] = 17 | (same - 3) << 8, same = 0;
        } else {
            runs[run_count++] = l, --same;
            for (; same >= 3; same -= std::min(same, 6)) runs[run_count++] = 16 | (std::min(same, 6) - 3) << 8;
        }
        for (; same > 0; --same) runs[run_count++] = l;
    }
    for (int r = 0; r < run_count; ++r) ++length_freq[runs[r] & 0xff];
    std::array<std::uint8_t, kCodeLengthSymbols> length_length{};
    code_lengths(length_freq.data(), kCodeLengthSymbols, 7, length_length.data());
    int order_count = kCodeLengthSymbols;
    while (order_count > 4 && length_length[kCodeLengthOrder[order_count - 1]] == 0) --order_count;

    constexpr int kRunExtra[3] = {2, 3, 7};
    std::uint64_t bits = 3 + 5 + 5 + 4 + 3 * std::uint64_t(order_count);
    for (int s = 0; s < kCodeLengthSymbols; ++s)
        bits += std::uint64_t{length_freq[s]} * (length_length[s] + (s >= 16 ? kRunExtra[s - 16] : 0));
    for (int s = 0; s < kLiterals; ++s)
        bits += std::uint64_t{literal_freq[s]} * (literal_length[s] + (s > 256 ? kLengthExtra[s - 257] : 0));
    for (int s = 0; s < kDistanceCodes; ++s)
        bits += std::uint64_t{distance_freq[s]} * (distance_length[s] + kDistanceExtra[s]);
    const std::uint64_t tail = last ? 0 : 3 + 7 + 32;  // the sync flush's empty stored block
    if ((bits + tail + 7) / 8 >= size + 5 * (size / 65535 + 1)) return stored(data, size, last);

    // ---- write ----
    std::array<std::uint16_t, kLiterals> literal_code{};
    std::array<std::uint16_t, kDistanceCodes> distance_code{};
    std::array<std::uint16_t, kCodeLengthSymbols> length_code{};
    canonical_codes(literal_length.data(), kLiterals, literal_code.data());
    canonical_codes(distance_length.data(), kDistanceCodes, distance_code.data());
    canonical_codes(length_length.data(), kCodeLengthSymbols, length_code.data());
    std::vector<std::uint8_t> out((bits + tail + 7) / 8 + 8);
    BitWriter w{out.data()};
    w.put(last ? 1 : 0, 1);
    w.put(2, 2);  // dynamic Huffman codes
    w.put(static_cast<std::uint32_t>(literal_count - 257), 5);
    w.put(static_cast<std::uint32_t>(distance_count - 1), 5);
    w.put(static_cast<std::uint32_t>(order_count - 4), 4);
    for (int k = 0; k < order_count; ++k) w.put(length_length[kCodeLengthOrder[k]], 3);
    for (int r = 0; r < run_count; ++r) {
        const int s = runs[r] & 0xff;
        w.put(length_code[s], length_length[s]);
        if (s >= 16) w.put(runs[r] >> 8, kRunExtra[s - 16]);
    }
    const std::uint8_t* literal = data;
    for (std::size_t k = 0; k < item_count; ++k) {
        const std::uint32_t item = items[k];
        if ((item & kMatch) == 0) {
            for (const std::uint8_t* run_end = literal + item; literal < run_end; ++literal)
                w.put(literal_code[*literal], literal_length[*literal]);
            continue;
        }
        const std::uint32_t length_minus_3 = (item >> 15) & 0xff, distance_minus_1 = item & 0x7fff;
        const int lc = t.length_code[length_minus_3];
        w.put(literal_code[257 + lc], literal_length[257 + lc]);
        w.put(length_minus_3 + 3 - kLengthBase[lc], kLengthExtra[lc]);
        const int dc = t.distance(distance_minus_1);
        w.put(distance_code[dc], distance_length[dc]);
        w.put(distance_minus_1 + 1 - kDistanceBase[dc], kDistanceExtra[dc]);
        literal += length_minus_3 + 3;
    }
    w.put(literal_code[kEndOfBlock], literal_length[kEndOfBlock]);
    if (!last) {
        w.put(0, 3);  // an empty stored block, as Z_SYNC_FLUSH ends a deflate call
        w.align();
        for (const std::uint8_t b : {0x00, 0x00, 0xff, 0xff}) *w.out++ = b;
    }
    w.align();
    out.resize(static_cast<std::size_t>(w.out - out.data()));
    return out;
}

}  // namespace tessref::image::detail
