/* The table file of a table curve read in C99 (see sm_table_file.h): TableCurve.from_csv's loop of
 * satmotor/machine/table_curve.py, its messages word for word.  No global mutable state. */
#include "sm_table_file.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

/* the reader's cells go whole through sm_parse_float */
typedef char sm_table_line_fits_parse_float[SM_TABLE_LINE_MAX <= SM_FLOAT_TEXT_MAX ? 1 : -1];

static int is_space(int ch)
{
    return ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r' || ch == '\v' || ch == '\f'
           || (ch >= 0x1c && ch <= 0x1f);
}

/* length of the UTF-8 encoded non-ASCII Unicode whitespace (str.isspace) starting at s, else 0 */
static size_t uspace_at(const unsigned char *s)
{
    if (s[0] == 0xC2 && (s[1] == 0x85 || s[1] == 0xA0)) return 2;
    if (s[0] == 0xE1 && s[1] == 0x9A && s[2] == 0x80) return 3;
    if (s[0] == 0xE2 && s[1] == 0x80 && ((s[2] >= 0x80 && s[2] <= 0x8A) || s[2] == 0xA8 || s[2] == 0xA9
                                         || s[2] == 0xAF)) return 3;
    if (s[0] == 0xE2 && s[1] == 0x81 && s[2] == 0x9F) return 3;
    if (s[0] == 0xE3 && s[1] == 0x80 && s[2] == 0x80) return 3;
    return 0;
}

/* str.strip() in place on UTF-8: returns the start, cuts the end */
static char *strip(char *s)
{
    size_t l, u;
    for (;;) {
        if (*s != '\0' && is_space((unsigned char)*s)) ++s;
        else if ((u = uspace_at((const unsigned char *)s)) > 0) s += u;
        else break;
    }
    l = strlen(s);
    for (;;) {
        if (l > 0 && is_space((unsigned char)s[l - 1])) s[--l] = '\0';
        else if (l >= 2 && uspace_at((const unsigned char *)s + l - 2) == 2) s[l -= 2] = '\0';
        else if (l >= 3 && uspace_at((const unsigned char *)s + l - 3) == 3) s[l -= 3] = '\0';
        else break;
    }
    return s;
}

#define SM_LINE_QUOTE_MAX 1024

static int bad_line(const char *src, int lineno, const char *line, char *msg, size_t msg_len)
{
    /* Python: ParameterError("table_file", f"line {lineno}: {line.strip()!r}", ...): a repr in a repr */
    /* the line is quoted up to SM_LINE_QUOTE_MAX bytes (a message buffer is shorter anyway) */
    char copy[SM_LINE_QUOTE_MAX + 1], inner[4 * SM_LINE_QUOTE_MAX + 8], val[4 * SM_LINE_QUOTE_MAX + 32];
    char rep[8 * SM_LINE_QUOTE_MAX + 64];
    size_t i = 0;
    while (*line != '\0' && is_space((unsigned char)*line)) ++line;
    for (; i < SM_LINE_QUOTE_MAX && line[i] != '\0'; ++i) copy[i] = line[i];
    copy[i] = '\0';
    sm_repr_str(strip(copy), inner, sizeof inner);
    snprintf(val, sizeof val, "line %d: %s", lineno, inner);
    sm_repr_str(val, rep, sizeof rep);
    return sm_param_error(msg, msg_len, src, "table_file", rep, "must hold two numeric columns i_mu, psi_m");
}

/* one line of the file (TableCurve.from_csv loop body): 0 skip, 1 point, 2 header, <0 error */
static int parse_line(char *line, double *a, double *b)
{
    char *p = line, *hash, *cells[3];
    int nc = 0, i;
    double v[2];
    hash = strchr(p, '#');
    if (hash != NULL) *hash = '\0';
    for (;;) {
        char *comma = strchr(p, ',');
        if (comma != NULL) *comma = '\0';
        if (nc < 3) cells[nc] = strip(p);
        ++nc;
        if (comma == NULL) break;
        p = comma + 1;
    }
    if (nc == 1 && cells[0][0] == '\0') return 0;
    for (i = 0; i < nc && i < 3; ++i) {
        double t;
        if (!sm_parse_float(cells[i], &t)) return 2; /* not numeric: the header if first */
        if (i < 2) v[i] = t;
    }
    if (nc != 2) return -1;
    *a = v[0];
    *b = v[1];
    return 1;
}

/* The file decodes as utf-8-sig (Python reads it so before any line): 0, or 1 with the text of
 * Python's UnicodeDecodeError in why (positions counted after a BOM). */
static int utf8_invalid(FILE *fh, char *why, size_t why_len)
{
    long pos = 0;
    int ch, k, need;
    unsigned char head[3];
    size_t nh = fread(head, 1, 3, fh);
    if (!(nh == 3 && head[0] == 0xEF && head[1] == 0xBB && head[2] == 0xBF)) {
        rewind(fh);
    }
    while ((ch = getc(fh)) != EOF) {
        unsigned lo = 0x80, hi = 0xBF;
        const char *reason = NULL;
        if (ch < 0x80) {
            ++pos;
            continue;
        }
        if (ch < 0xC2 || ch > 0xF4) {
            snprintf(why, why_len, "'utf-8' codec can't decode byte 0x%02x in position %ld: invalid start byte",
                     (unsigned)ch, pos);
            return 1;
        }
        need = ch < 0xE0 ? 1 : (ch < 0xF0 ? 2 : 3);
        if (ch == 0xE0) lo = 0xA0;
        else if (ch == 0xED) hi = 0x9F;
        else if (ch == 0xF0) lo = 0x90;
        else if (ch == 0xF4) hi = 0x8F;
        for (k = 1; k <= need; ++k) {
            int c2 = getc(fh);
            if (c2 == EOF) reason = "unexpected end of data";
            else if ((unsigned)c2 < lo || (unsigned)c2 > hi) reason = "invalid continuation byte";
            if (reason != NULL) break;
            lo = 0x80;
            hi = 0xBF;
        }
        if (reason != NULL) {
            if (k == 1)
                snprintf(why, why_len, "'utf-8' codec can't decode byte 0x%02x in position %ld: %s", (unsigned)ch,
                         pos, reason);
            else
                snprintf(why, why_len, "'utf-8' codec can't decode bytes in position %ld-%ld: %s", pos,
                         pos + k - 1, reason);
            return 1;
        }
        pos += need + 1;
    }
    rewind(fh);
    return 0;
}

int sm_table_file_read(const char *path, int max_points, double *i_mu, double *psi_m, int *lines, int *n_points,
                       char *msg, size_t msg_len)
{
    char line[SM_TABLE_LINE_MAX + 2], work[SM_TABLE_LINE_MAX + 2], rp[1200], reason[1400];
    FILE *fh;
    int rows = 0, header = 0, lineno = 0, ch, eof = 0, first = 1;
    if (msg != NULL && msg_len > 0) msg[0] = '\0';
    if (path == NULL || max_points < 0 || i_mu == NULL || psi_m == NULL || lines == NULL || n_points == NULL)
        return SM_ERR_ARG;
    fh = fopen(path, "rb");
    if (fh == NULL) {
        int e = errno;
        char rq[1200];
        snprintf(reason, sizeof reason, "cannot be read: [Errno %d] %s: %s", e, strerror(e),
                 sm_repr_str(path, rq, sizeof rq));
        return sm_param_error(msg, msg_len, NULL, "table_file", sm_repr_str(path, rp, sizeof rp), reason);
    }
    {
        char why[200];
        if (utf8_invalid(fh, why, sizeof why)) {
            fclose(fh);
            snprintf(reason, sizeof reason, "cannot be read: %s", why);
            return sm_param_error(msg, msg_len, NULL, "table_file", sm_repr_str(path, rp, sizeof rp), reason);
        }
    }
    while (!eof) {
        size_t len = 0;
        int nul = 0, any = 0, toolong = 0, st;
        double a, b;
        /* str.splitlines: \n, \r, \r\n, \v, \f, \x1c, \x1d, \x1e, U+0085, U+2028, U+2029 end a line */
        for (;;) {
            ch = getc(fh);
            if (ch == EOF) { eof = 1; break; }
            any = 1;
            if (ch == '\n' || ch == '\v' || ch == '\f' || ch == 0x1c || ch == 0x1d || ch == 0x1e) break;
            if (ch == '\r') {
                int nx = getc(fh);
                if (nx != '\n' && nx != EOF) ungetc(nx, fh);
                break;
            }
            if (ch == 0xC2 || ch == 0xE2) { /* U+0085, U+2028, U+2029 (the file is valid UTF-8) */
                int c2 = getc(fh), c3 = ch == 0xE2 ? getc(fh) : EOF;
                if ((ch == 0xC2 && c2 == 0x85) || (ch == 0xE2 && c2 == 0x80 && (c3 == 0xA8 || c3 == 0xA9)))
                    break;
                if (len + 3 <= SM_TABLE_LINE_MAX) {
                    line[len++] = (char)ch;
                    if (c2 != EOF) line[len++] = (char)c2;
                    if (c3 != EOF) line[len++] = (char)c3;
                } else {
                    toolong = 1;
                }
                continue;
            }
            if (ch == 0) nul = 1;
            if (len < SM_TABLE_LINE_MAX) line[len++] = (char)ch;
            else toolong = 1;
        }
        if (!any) break;
        line[len] = '\0';
        ++lineno;
        if (first) { /* utf-8-sig: drop a BOM */
            first = 0;
            if ((unsigned char)line[0] == 0xEF && (unsigned char)line[1] == 0xBB && (unsigned char)line[2] == 0xBF)
            {
                memmove(line, line + 3, len - 3 + 1);
                len -= 3;
            }
        }
        if (toolong) {
            char val[64];
            fclose(fh);
            snprintf(val, sizeof val, "line %d", lineno);
            snprintf(reason, sizeof reason, "is longer than %d bytes (the native limit SM_TABLE_LINE_MAX)",
                     SM_TABLE_LINE_MAX);
            return sm_param_error(msg, msg_len, path, "table_file", sm_repr_str(val, rp, sizeof rp), reason);
        }
        memcpy(work, line, sizeof work);
        /* a NUL byte: Python's float() fails on the cell, so the line is not numeric */
        st = nul ? 2 : parse_line(work, &a, &b);
        if (st == 0) continue;
        if (st == 2 && rows == 0 && !header) {
            header = 1;
            continue;
        }
        if (st != 1) {
            fclose(fh);
            return bad_line(path, lineno, line, msg, msg_len);
        }
        if (rows > max_points) continue; /* counted, rejected below */
        i_mu[rows] = a;
        psi_m[rows] = b;
        lines[rows] = lineno;
        ++rows;
    }
    if (ferror(fh)) {
        int e = errno;
        char rq[1200];
        fclose(fh);
        snprintf(reason, sizeof reason, "cannot be read: [Errno %d] %s: %s", e, strerror(e),
                 sm_repr_str(path, rq, sizeof rq));
        return sm_param_error(msg, msg_len, NULL, "table_file", sm_repr_str(path, rp, sizeof rp), reason);
    }
    fclose(fh);
    if (rows == 0)
        return sm_param_error(msg, msg_len, path, "table_file", sm_repr_str(path, rp, sizeof rp),
                              "holds no points i_mu, psi_m");
    if (rows > max_points) {
        snprintf(reason, sizeof reason, "has more than %d points (the native limit SM_TABLE_MAX)", max_points);
        return sm_param_error(msg, msg_len, path, "table_file", sm_repr_str(path, rp, sizeof rp), reason);
    }
    *n_points = rows;
    return SM_CORE_OK;
}
