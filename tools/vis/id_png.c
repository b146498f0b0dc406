/* id_png.c — ID buffers as PNG pictures (libpng's simplified API, when the build has libpng),
 * written through out_file.h. */
#include "id_png.h"

#include <stdio.h>
#include <stdlib.h>

#include "out_file.h"

#ifdef VIS_HAVE_PNG
#include <png.h>
#endif

uint32_t cli_id_colour(uint32_t id)
{
    if (id == 0)
        return 0;
    /* A 32-bit integer hash (the murmur3 finaliser): neighbouring IDs get unrelated colours. */
    uint32_t h = id;
    h ^= h >> 16;
    h *= 0x85ebca6bu;
    h ^= h >> 13;
    h *= 0xc2b2ae35u;
    h ^= h >> 16;
    /* Each channel in [48, 255]: bright enough never to be mistaken for "nothing". */
    uint32_t r = 48 + (h & 0xFFu) % 208, g = 48 + ((h >> 8) & 0xFFu) % 208, b = 48 + ((h >> 16) & 0xFFu) % 208;
    return r << 16 | g << 8 | b;
}

int cli_png_available(void)
{
#ifdef VIS_HAVE_PNG
    return 1;
#else
    return 0;
#endif
}

int cli_png_write_ids(const char *path, const uint32_t *ids, uint32_t width, uint32_t height, char *err,
                      size_t err_size)
{
#ifdef VIS_HAVE_PNG
    size_t n = (size_t)width * height;
    unsigned char *rgb = malloc(n * 3);
    if (!rgb) {
        snprintf(err, err_size, "out of memory for a %ux%u picture", width, height);
        return -1;
    }
    for (size_t i = 0; i < n; ++i) {
        uint32_t c = cli_id_colour(ids[i]);
        rgb[3 * i + 0] = (unsigned char)(c >> 16);
        rgb[3 * i + 1] = (unsigned char)(c >> 8);
        rgb[3 * i + 2] = (unsigned char)c;
    }
    png_image image = {0};
    image.version = PNG_IMAGE_VERSION;
    image.width = width;
    image.height = height;
    image.format = PNG_FORMAT_RGB;
    /* Encoded in memory, then written by vc_write_file: libpng's own file writer remove()s
     * the file it named when a write fails, and `--png /dev/full` as root deleted /dev/full. */
    png_alloc_size_t size = PNG_IMAGE_PNG_SIZE_MAX(image);
    void *png = malloc(size);
    if (!png) {
        free(rgb);
        snprintf(err, err_size, "out of memory for a %ux%u picture", width, height);
        return -1;
    }
    int ok = png_image_write_to_memory(&image, png, &size, 0, rgb, (png_int_32)(width * 3), NULL);
    free(rgb);
    if (!ok) {
        snprintf(err, err_size, "encoding %s: %s", path, image.message);
        png_image_free(&image);
        free(png);
        return -1;
    }
    int rc = vc_write_file(path, png, size, err, err_size);
    free(png);
    return rc;
#else
    (void)ids;
    (void)width;
    (void)height;
    snprintf(err, err_size, "--png is not available in this build (libpng was not found); cannot write %s", path);
    return -1;
#endif
}
