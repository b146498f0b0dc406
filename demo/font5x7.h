/* font5x7.h — the HUD's own 5x7 bitmap font (font5x7.c). */
#ifndef VIS_VIEWER_FONT5X7_H
#define VIS_VIEWER_FONT5X7_H

#include <stdint.h>

#define VV_FONT_W 5
#define VV_FONT_H 7

/* The glyph of c as VV_FONT_H rows, bit (VV_FONT_W - 1 - x) lit for column x; lower case
 * maps to capitals. 0 (and nothing written) when the font has no such glyph. */
int vv_font_glyph(char c, uint8_t out_rows[VV_FONT_H]);

#endif
