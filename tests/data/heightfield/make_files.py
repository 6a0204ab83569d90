#!/usr/bin/env python3
"""Writes the hostile height maps of tests/test_heightfield.cpp and tests/test_mesh.cpp:
tiny files, each with one stated defect (or one stated edge case), that a loader must
refuse with an error naming the file, or accept. The files are committed; this script
documents how they were made and regenerates them (python3, standard library only):

    python3 tests/data/heightfield/make_files.py
"""
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))


def write(name, data):
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data)


def pfm(width, height, values, scale=b"-1.0"):
    """A grayscale PFM, little endian (negative scale), rows bottom to top as stored."""
    return b"Pf\n%d %d\n" % (width, height) + scale + b"\n" + struct.pack("<%df" % len(values), *values)


def png_chunk(kind, data, crc=None):
    crc = zlib.crc32(kind + data) if crc is None else crc
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc & 0xFFFFFFFF)


def png_gray8(width, height, rows_bytes, ihdr_crc=None, idat=None):
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    raw = b"".join(b"\x00" + row for row in rows_bytes)
    return (b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr, ihdr_crc) +
            png_chunk(b"IDAT", zlib.compress(raw) if idat is None else idat) + png_chunk(b"IEND", b""))


def tiff_gray8(width, height, strip_offset=None, strip_bytes=None, pixels=b""):
    """A little-endian baseline TIFF, one strip of 8-bit gray; the IFD follows the header."""
    entries = [
        (256, 3, 1, width),            # ImageWidth
        (257, 3, 1, height),           # ImageLength
        (258, 3, 1, 8),                # BitsPerSample
        (259, 3, 1, 1),                # Compression: none
        (262, 3, 1, 1),                # Photometric: black is zero
        (273, 4, 1, 0),                # StripOffsets (patched below)
        (277, 3, 1, 1),                # SamplesPerPixel
        (278, 3, 1, height),           # RowsPerStrip
        (279, 4, 1, width * height),   # StripByteCounts
    ]
    ifd_size = 2 + 12 * len(entries) + 4
    data_offset = 8 + ifd_size
    if strip_offset is None:
        strip_offset = data_offset
    if strip_bytes is None:
        strip_bytes = width * height
    ifd = struct.pack("<H", len(entries))
    for tag, kind, count, value in entries:
        if tag == 273:
            value = strip_offset
        if tag == 279:
            value = strip_bytes
        packed = struct.pack("<H", value) + b"\0\0" if kind == 3 else struct.pack("<I", value)
        ifd += struct.pack("<HHI", tag, kind, count) + packed
    ifd += struct.pack("<I", 0)
    return b"II*\x00" + struct.pack("<I", 8) + ifd + pixels


# ---- PGM (netpbm: maxval 1..65535; above 255 two bytes per sample, big endian) ----------
# maxval 0: OpenImageIO 2.4.7 accepts it (every sample reads as 1).
write("maxval_0.pgm", b"P5\n2 2\n0\n\x00\x00\x00\x00")
# maxval 70000: above the format's 65535; OpenImageIO reads 16-bit samples scaled by 70000.
write("maxval_70000.pgm", b"P5\n2 2\n70000\n" + struct.pack(">4H", 0, 100, 35000, 65535))
# maxval 65535, the largest allowed: codes 0, 100, 1000, 30000 (all <= 32768, which
# OpenImageIO 2.4.7 reads exactly; see Loading.Pgm16Above32768).
write("maxval_65535.pgm", b"P5\n2 2\n65535\n" + struct.pack(">4H", 0, 100, 1000, 30000))
# A header that declares 100000 x 100000 samples (10^10 bytes) over 4 bytes of data.
write("declares_100000x100000.pgm", b"P5\n100000 100000\n255\nabcd")
# A header that declares 3000 x 3000 samples over 4 bytes: fits a raised memory limit,
# then fails as truncated.
write("declares_3000x3000.pgm", b"P5\n3000 3000\n255\nabcd")
write("zero_size.pgm", b"P5\n0 0\n255\n")
write("one_by_one.pgm", b"P5\n1 1\n255\n\x07")

# ---- PFM (scale line: non-zero; its sign gives the byte order) --------------------------
write("pfm_bad_scale.pfm", b"Pf\n2 2\nabc\n" + struct.pack("<4f", 1, 2, 3, 4))
write("pfm_zero_scale.pfm", pfm(2, 2, [1, 2, 3, 4], scale=b"0"))
write("pfm_negative_width.pfm", b"Pf\n-2 2\n-1.0\n" + struct.pack("<4f", 1, 2, 3, 4))
write("pfm_zero_width.pfm", b"Pf\n0 2\n-1.0\n" + struct.pack("<4f", 1, 2, 3, 4))
# A NaN sample: stored row 0 (the bottom row), column 1, i.e. texel (1, 2) of a 3 x 3
# map once OpenImageIO has flipped it to top-first order.
write("nan_sample.pfm", pfm(3, 3, [1, float("nan"), 1, 1, 1, 1, 1, 1, 1]))
# One huge but finite sample: 3e38 (a float; FLT_MAX is 3.4e38). Times scale_z = 10 the
# height overflows float. Stored row 1, column 1 of 4 x 4: texel (1, 2) top-first.
write("huge_sample.pfm", pfm(4, 4, [1.0] * 5 + [3e38] + [1.0] * 10))
# Flat, all 0.5: for the far-from-the-origin scene.
write("flat.pfm", pfm(4, 4, [0.5] * 16))

# ---- PNG and TIFF -------------------------------------------------------------------------
rows = [bytes([10, 20, 30]), bytes([40, 50, 60]), bytes([70, 80, 90])]
# The IHDR chunk's CRC is wrong: libpng refuses the header.
write("png_bad_header_crc.png", png_gray8(3, 3, rows, ihdr_crc=0x12345678))
# The header is sound, the IDAT chunk holds bytes that are not a zlib stream.
write("png_bad_pixel_data.png", png_gray8(3, 3, rows, idat=b"definitely not zlib data"))
# The first IFD offset points past the end of the file.
write("tiff_bad_ifd_offset.tif", b"II*\x00" + struct.pack("<I", 4096) + b"\0" * 8)
# A sound 3 x 3 IFD whose one strip lies past the end of the file.
write("tiff_strip_past_end.tif", tiff_gray8(3, 3, strip_offset=100000))
