/* gl_util.h — shader compiling and the GL error check every part of the viewer uses. */
#ifndef VIS_VIEWER_GL_UTIL_H
#define VIS_VIEWER_GL_UTIL_H

#include <epoxy/gl.h>

/* Compiles and links a vertex + fragment program; 0 after printing the log on failure. */
GLuint vv_gl_program(const char *what, const char *vs, const char *fs);

/* Drains glGetError; prints each error with `where` and returns how many there were. */
int vv_gl_errors(const char *where);

/* A column-major double matrix as the floats GL takes. */
void vv_gl_matrix(const double m[16], float out[16]);

#endif
