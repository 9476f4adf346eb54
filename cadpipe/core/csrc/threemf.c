/* cadpipe's own scan of a 3MF model's vertex and triangle tables (cadpipe.io.threemf):
 * nearly all of a file's bytes are rows like <vertex x="1" y="2" z="3"/>, read here
 * straight into arrays; anything else in a table (comments, entities, other elements, a
 * malformed number) makes the scan give up, and the Python side reads the model with
 * ElementTree instead.
 *
 * Numbers are parsed exactly: Clinger's fast path (an integer mantissa of at most 18
 * digits, up to 2**53, times or divided by an exact power of ten up to 10**22 rounds once,
 * correctly); any other is left for a full parse (Python's), gathered as text. */
#include "native.h"

/* 10**k for k in 0..22, exact in float64 */
static const double threemf_powers[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                          1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                          1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

static inline int threemf_blank(uint8_t c) { return c == 32 || c == 10 || c == 13 || c == 9; }

/* The position of the first byte at or after ``at`` (below ``stop``) that is not XML
 * white space. */
static inline int64_t threemf_skip_blanks(const uint8_t *text, int64_t at, int64_t stop)
{
    while (at < stop && threemf_blank(text[at]))
        at++;
    return at;
}

/* The number text[start:stop] (3MF's ST_Number; an integer where ``integer``) into
 * ``*value``; returns 0 read, 1 exact only by a full parse (more than 18 digits, or
 * beyond 2**53 or 10**22), 2 not a number. Integers come back as floats only up to
 * 2**53; larger ones are 2 (no vertex index is that large). */
static int threemf_number(const uint8_t *text, int64_t start, int64_t stop, int integer,
                          double *value)
{
    int64_t at = start;
    int negative = 0;
    *value = 0.0;
    if (at < stop && (text[at] == 45 || text[at] == 43)) {      /* '-' or '+' */
        negative = text[at] == 45;
        at++;
    }
    int64_t mantissa = 0, scale = 0;
    int digits = 0, inexact = 0, seen = 0, point = 0;
    for (; at < stop; at++) {
        uint8_t c = text[at];
        if (c == 46 && !point && !integer)                       /* '.' */
            point = 1;
        else if (c >= 48 && c <= 57) {
            seen = 1;
            if (mantissa == 0 && c == 48) {
                if (point)                                       /* a leading zero */
                    scale--;
            } else if (digits < 18) {
                mantissa = mantissa * 10 + (c - 48);
                digits++;
                if (point)
                    scale--;
            } else {
                inexact |= c != 48;                              /* a dropped digit */
                if (!point)
                    scale++;
            }
        } else
            break;
    }
    if (!seen)
        return 2;
    if (at < stop && (text[at] == 101 || text[at] == 69) && !integer) {    /* 'e', 'E' */
        at++;
        int64_t sign = 1;
        if (at < stop && (text[at] == 45 || text[at] == 43)) {
            sign = text[at] == 45 ? -1 : 1;
            at++;
        }
        int64_t exponent = 0;
        int given = 0;
        while (at < stop && text[at] >= 48 && text[at] <= 57 && exponent < 100000) {
            exponent = exponent * 10 + (text[at] - 48);
            given = 1;
            at++;
        }
        if (!given)
            return 2;
        scale += sign * exponent;
    }
    if (at != stop || (integer && negative && mantissa))
        return 2;
    double v = (double)mantissa;
    if (mantissa == 0)
        v = 0.0;
    else if (inexact || mantissa > ((int64_t)1 << 53) || scale < -22 || scale > 22)
        return integer ? 2 : 1;
    else if (scale < 0)
        v /= threemf_powers[-scale];
    else
        v *= threemf_powers[scale];
    *value = negative ? -v : v;
    return 0;
}

/* extent_3mf(text (N,) uint8, start, element (W,) uint8) -> (rows, stop): how many
 * ``<element`` rows the table from text[start] holds and where the closing tag after them
 * starts; (-1, -1) for any other markup in it (comments, other elements). */
KERNEL(extent_3mf)
{
    CP_NARGS(3);
    IN_U8(0, text_arr, 1);
    IN_LONG(1, start);
    IN_U8(2, element_arr, 1);
    const uint8_t *text = U8(text_arr), *element = U8(element_arr);
    int64_t n = text_arr.size, width = element_arr.size, rows = 0, at = start, stop = -1;
    if (start < 0) {
        PyErr_SetString(PyExc_ValueError, "extent_3mf: start >= 0");
        return NULL;
    }
    for (;;) {
        while (at < n && text[at] != 60)                         /* '<' */
            at++;
        if (at + 2 + width >= n) {
            rows = -1;
            break;
        }
        int closing = text[at + 1] == 47;                        /* '/' */
        int64_t first = at + 1 + closing;
        int same = 1;
        for (int64_t i = 0; i < width; i++)
            if (text[first + i] != element[i]) {
                same = 0;
                break;
            }
        uint8_t follows = text[first + width];
        int ends = threemf_blank(follows) || follows == 62 || (follows == 47 && !closing);
        if (!(same && ends)) {
            if (closing)
                stop = at;
            else
                rows = -1;
            break;
        }
        rows += !closing;
        at = first;
    }
    return rows < 0 ? Py_BuildValue("ii", -1, -1) : Py_BuildValue("LL", (long long)rows,
                                                                   (long long)stop);
}

/* The table's arrays (see scan_3mf). */
typedef struct {
    const uint8_t *text, *element, *keys;
    int64_t width, key_room, columns;
    const int64_t *lengths;
    double *floats;
    int64_t *ints, *extra;
    int64_t rows, extra_columns;
    int integer;
    uint8_t *spans;
    int64_t *where;
    int64_t span_room, where_room;
    int64_t *slow;
} Table;

/* scan_3mf's pass over text[start:stop]: 1 read, 0 not readable here. */
static int threemf_scan(const Table *t, int64_t start, int64_t stop)
{
    const uint8_t *text = t->text, *element = t->element;
    int64_t width = t->width, rows = t->rows;
    int64_t at = start, row = 0, count = 0, used = 0;
    int gather = t->where_room > 0;
    for (;;) {
        at = threemf_skip_blanks(text, at, stop);
        if (at >= stop)
            break;
        if (text[at] != 60 || row >= rows || at + 1 + width > stop)
            return 0;
        at++;
        for (int64_t i = 0; i < width; i++)
            if (text[at + i] != element[i])
                return 0;
        at += width;
        int64_t found = 0;
        for (;;) {
            int64_t after = at;
            at = threemf_skip_blanks(text, at, stop);
            if (at >= stop)
                return 0;
            uint8_t c = text[at];
            if (c == 47) {                                      /* "/>" */
                if (at + 1 >= stop || text[at + 1] != 62)
                    return 0;
                at += 2;
                break;
            }
            if (c == 62) {                                      /* ">" ... "</element>" */
                at = threemf_skip_blanks(text, at + 1, stop);
                if (at + 2 + width >= stop || text[at] != 60 || text[at + 1] != 47)
                    return 0;
                at += 2;
                for (int64_t i = 0; i < width; i++)
                    if (text[at + i] != element[i])
                        return 0;
                at = threemf_skip_blanks(text, at + width, stop);
                if (at >= stop || text[at] != 62)
                    return 0;
                at++;
                break;
            }
            if (after == at)                          /* attributes need blanks between */
                return 0;
            int64_t name = at;
            while (at < stop && text[at] != 61 && text[at] > 32 && text[at] != 62 &&
                   text[at] != 47)
                at++;
            int64_t name_end = at;
            at = threemf_skip_blanks(text, at, stop);
            if (at >= stop || text[at] != 61)                    /* '=' */
                return 0;
            at = threemf_skip_blanks(text, at + 1, stop);
            if (at >= stop || (text[at] != 34 && text[at] != 39)) /* a quote */
                return 0;
            uint8_t quote = text[at];
            int64_t value = at + 1;
            for (at = value; at < stop && text[at] != quote; at++)
                if (text[at] == 38 || text[at] == 60)  /* an entity or "<": not read here */
                    return 0;
            if (at >= stop)
                return 0;
            int64_t value_end = at;
            at++;
            int64_t column = -1;
            for (int64_t k = 0; k < t->columns; k++) {
                int64_t length = t->lengths[k];
                if (length == name_end - name &&
                    memcmp(text + name, t->keys + k * t->key_room, (size_t)length) == 0) {
                    column = k;
                    break;
                }
            }
            if (column < 0)
                continue;                                /* an attribute not asked for */
            if (found & ((int64_t)1 << column))
                return 0;
            found |= (int64_t)1 << column;
            double number;
            int state = threemf_number(text, value, value_end, t->integer, &number);
            if (state == 2)
                return 0;
            if (column >= 3) {
                t->extra[row * t->extra_columns + column - 3] = (int64_t)number;
                t->slow[2] = 1;
            } else if (t->integer)
                t->ints[row * 3 + column] = (int64_t)number;
            else if (state == 0)
                t->floats[row * 3 + column] = number;
            else {
                if (gather) {
                    if (count >= t->where_room || used + value_end - value + 1 > t->span_room)
                        return 0;
                    t->where[count] = row * t->columns + column;
                    memcpy(t->spans + used, text + value, (size_t)(value_end - value));
                    used += value_end - value;
                    t->spans[used++] = 32;
                } else
                    used += value_end - value + 1;
                count++;
            }
        }
        if ((found & 7) != 7)
            return 0;
        row++;
    }
    t->slow[0] = count;
    t->slow[1] = used;
    return row == rows;
}

/* scan_3mf(text, start, stop, element, keys (K, L) uint8, lengths (K,) int64, floats
 * (R, 3) float64, ints (R, 3) int64, extra (R, K - 3) int64, integer, spans uint8, where
 * int64, slow (3,) int64) -> bool: read a table of ``<element a="..." .../>`` rows
 * (text[start:stop], blanks between them): the value of attribute keys[k][:lengths[k]]
 * goes to column k of ``ints`` (where ``integer``) or ``floats`` (the other one is (0,
 * 3)) for the first three (required), of ``extra`` (slow[2] set where any is given) for
 * the rest. False for what this scan does not read (comments, entities, other elements,
 * a row too many or few, a malformed number): the caller then uses ElementTree. Numbers
 * that need an exact full parse are counted in slow[:2] (count, bytes) and, when
 * ``where`` has room, their text is gathered into ``spans`` (blank-separated) and their
 * flat positions into ``where``. */
KERNEL(scan_3mf)
{
    CP_NARGS(13);
    IN_U8(0, text, 1);
    IN_LONG(1, start);
    IN_LONG(2, stop);
    IN_U8(3, element, 1);
    IN_U8(4, keys, 2);
    IN_I64(5, lengths, 1);
    OUT_F64(6, floats, 2);
    OUT_I64(7, ints, 2);
    OUT_I64(8, extra, 2);
    IN_FLAG(9, integer);
    OUT_U8(10, spans, 1);
    OUT_I64(11, where, 1);
    OUT_I64(12, slow, 1);
    Table t = {U8(text), U8(element), U8(keys), element.size, keys.shape[1], keys.shape[0],
               I64(lengths), F64(floats), I64(ints), I64(extra), extra.shape[0],
               extra.shape[1], integer, U8(spans), I64(where), spans.size, where.size,
               I64(slow)};
    int valid = start >= 0 && start <= stop && stop <= text.size && t.columns >= 3 &&
                t.columns <= 62 && (t.columns == 3 || integer) && lengths.size == t.columns && slow.size == 3 &&
                t.extra_columns == t.columns - 3 && floats.shape[1] == 3 &&
                ints.shape[1] == 3 && (integer ? ints.shape[0] : floats.shape[0]) == t.rows;
    for (int64_t k = 0; valid && k < t.columns; k++)
        valid = t.lengths[k] >= 0 && t.lengths[k] <= t.key_room;
    if (!valid) {
        PyErr_SetString(PyExc_ValueError, "scan_3mf: arrays unlike a table's (see threemf.py)");
        return NULL;
    }
    int read;
    Py_BEGIN_ALLOW_THREADS
    read = threemf_scan(&t, start, stop);
    Py_END_ALLOW_THREADS
    return PyBool_FromLong(read);
}

/* number_3mf(text (N,) uint8, start, stop, integer) -> (value, state): threemf_number of
 * text[start:stop], for tests (the scan calls the C function itself). */
KERNEL(number_3mf)
{
    CP_NARGS(4);
    IN_U8(0, text, 1);
    IN_LONG(1, start);
    IN_LONG(2, stop);
    IN_FLAG(3, integer);
    if (start < 0 || start > stop || stop > text.size) {
        PyErr_SetString(PyExc_ValueError, "number_3mf: 0 <= start <= stop <= len(text)");
        return NULL;
    }
    double value;
    int state = threemf_number(U8(text), start, stop, integer, &value);
    return Py_BuildValue("di", value, state);
}

static PyMethodDef threemf_methods[] = {
    ENTRY(extent_3mf, "Rows of a 3MF table and where its closing tag starts (io.threemf)."),
    ENTRY(scan_3mf, "Read a 3MF vertex or triangle table into arrays; False: not here."),
    ENTRY(number_3mf, "One 3MF number as the scan parses it: (value, state)."),
    END_ENTRIES};
