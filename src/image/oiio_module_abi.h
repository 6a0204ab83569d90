/* src/image/oiio_module_abi.h — the C interface between libtessref and its OpenImageIO
 * module, tessref_oiio.so (src/image/oiio/module.cpp).
 *
 * The module is the only code of tessref that links OpenImageIO; libtessref dlopens it on
 * the first image that needs it (src/image/oiio_module.cpp), so that a process that reads
 * and writes PNG and PNM only never loads OpenImageIO and the ~270 libraries it needs.
 * One exported symbol, tessref_oiio_entry(abi), returns a table of functions. Every
 * function reports failure as a nonzero return with its reason written, NUL-terminated
 * and cut to fit, into the caller's `error` buffer; nothing throws across this boundary.
 * Plain C types only: the module and the library need not share a C++ standard library
 * layout. Bump TESSREF_OIIO_ABI on any change to this file. */
#ifndef TESSREF_IMAGE_OIIO_MODULE_ABI_H
#define TESSREF_IMAGE_OIIO_MODULE_ABI_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#define TESSREF_OIIO_ABI 1
#define TESSREF_OIIO_ENTRY "tessref_oiio_entry"

/* Sample types of the buffers that cross the interface. */
enum tessref_oiio_type { TESSREF_OIIO_UINT8 = 0, TESSREF_OIIO_UINT16 = 1, TESSREF_OIIO_FLOAT = 2 };

/* What an open file's header says (subimage 0, mip level 0). */
typedef struct tessref_oiio_header {
    int width, height, depth, channels;
    int deep;                 /* a deep image: no flat pixels to read */
    int per_channel_formats;  /* channels stored in different types (EXR) */
    int type;                 /* enum tessref_oiio_type: UINT8 and UINT16 files as such, FLOAT otherwise */
    int bits_per_sample;      /* oiio:BitsPerSample where the reader gives it, else 0 */
    int alpha_channel;        /* -1 for none */
    char pixel_type[32];      /* the file's sample type as OpenImageIO names it ("uint8", "half", ...) */
    char format_name[32];     /* the reader's name ("openexr", "tiff", ...) */
} tessref_oiio_header;

typedef struct tessref_oiio_reader tessref_oiio_reader;

/* An image to write: `pixels` holds height rows of width * channels samples of `type`,
 * top row first. channel_names may be null (OpenImageIO's defaults); compression and
 * software may be null (the format's default; no Software attribute). No time stamp is
 * ever written. */
typedef struct tessref_oiio_image {
    int width, height, channels, type;
    const void* pixels;
    const char* const* channel_names;
    int alpha_channel, z_channel;
    const char* compression;
    const char* software;
} tessref_oiio_image;

/* A caller-owned picture that drawing operations paint into, in place. */
typedef struct tessref_oiio_canvas {
    void* pixels;
    int width, height, channels, type; /* type: UINT8 or FLOAT */
} tessref_oiio_canvas;

enum tessref_oiio_draw_kind {
    TESSREF_OIIO_LINE = 0,      /* ImageBufAlgo::render_line from (x0, y0) to (x1, y1) */
    TESSREF_OIIO_POINT = 1,     /* render_point at (x0, y0) */
    TESSREF_OIIO_BOX = 2,       /* render_box (x0, y0)-(x1, y1), outline */
    TESSREF_OIIO_FILLED_BOX = 3,/* render_box, filled */
    TESSREF_OIIO_TEXT = 4       /* render_text, baseline at (x0, y0), x1: 0 left, 1 centre, 2 right */
};

typedef struct tessref_oiio_draw {
    int kind;
    int x0, y0, x1, y1;
    float colour[4];  /* the canvas's channels, in [0, 1] */
    int size;        /* text: font size in pixels */
    const char* text;
    const char* font;
} tessref_oiio_draw;

typedef struct tessref_oiio_api {
    int abi; /* TESSREF_OIIO_ABI */
    /* The OpenImageIO version the module was built against, as "2.4.7". */
    const char* (*oiio_version)(void);
    /* Opens `path` and reads its header; *reader must be closed with close_reader. */
    int (*open_reader)(const char* path, tessref_oiio_reader** reader, tessref_oiio_header* header, char* error,
                       size_t error_size);
    /* The name of channel `c` of an open reader (valid until it is closed). */
    const char* (*channel_name)(const tessref_oiio_reader* reader, int c);
    /* Reads channels [0, channels) of every pixel into `pixels` as `type`. Colour is never
     * premultiplied by alpha. A read that OpenImageIO reports as done but with its error
     * set counts as failed. */
    int (*read_pixels)(tessref_oiio_reader* reader, int channels, int type, void* pixels, char* error,
                       size_t error_size);
    void (*close_reader)(tessref_oiio_reader* reader);
    /* Whether OpenImageIO has a writer for this file name (by its extension): 0 yes. */
    int (*can_write)(const char* path, char* error, size_t error_size);
    /* Whether this file name's format is written as float (OpenEXR): 1 yes, 0 no. */
    int (*writes_float)(const char* path);
    int (*write_image)(const char* path, const tessref_oiio_image* image, char* error, size_t error_size);
    /* Paints ops[0 .. count) in order. An operation that fails (text without a font) is
     * skipped; the first failure's index goes to *failed and its reason to `error`, and
     * with stop_at_failure nothing after it is drawn. Returns 0 when every one succeeded. */
    int (*draw)(const tessref_oiio_canvas* canvas, const tessref_oiio_draw* ops, size_t count,
                int stop_at_failure, size_t* failed, char* error, size_t error_size);
} tessref_oiio_api;

typedef const tessref_oiio_api* (*tessref_oiio_api_fn)(int abi);

#ifdef __cplusplus
}
#endif

#endif
