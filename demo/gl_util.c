/* gl_util.c — shader compiling and GL error reporting. */
#include "gl_util.h"

#include <stdio.h>

static GLuint compile(const char *what, GLenum type, const char *src)
{
    GLuint s = glCreateShader(type);
    glShaderSource(s, 1, &src, NULL);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[2048];
        glGetShaderInfoLog(s, sizeof log, NULL, log);
        fprintf(stderr, "vis-viewer: %s %s shader: %s\n", what, type == GL_VERTEX_SHADER ? "vertex" : "fragment", log);
        glDeleteShader(s);
        return 0;
    }
    return s;
}

GLuint vv_gl_program(const char *what, const char *vs, const char *fs)
{
    GLuint v = compile(what, GL_VERTEX_SHADER, vs), f = compile(what, GL_FRAGMENT_SHADER, fs);
    if (!v || !f) {
        if (v)
            glDeleteShader(v);
        if (f)
            glDeleteShader(f);
        return 0;
    }
    GLuint p = glCreateProgram();
    glAttachShader(p, v);
    glAttachShader(p, f);
    glLinkProgram(p);
    glDeleteShader(v);
    glDeleteShader(f);
    GLint ok = 0;
    glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[2048];
        glGetProgramInfoLog(p, sizeof log, NULL, log);
        fprintf(stderr, "vis-viewer: %s program: %s\n", what, log);
        glDeleteProgram(p);
        return 0;
    }
    return p;
}

int vv_gl_errors(const char *where)
{
    int n = 0;
    GLenum e;
    while ((e = glGetError()) != GL_NO_ERROR && n < 16) {
        fprintf(stderr, "vis-viewer: GL error 0x%04x after %s\n", (unsigned)e, where);
        ++n;
    }
    return n;
}

void vv_gl_matrix(const double m[16], float out[16])
{
    for (int i = 0; i < 16; ++i)
        out[i] = (float)m[i];
}
