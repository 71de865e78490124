// Internal: bytes read from a file, made safe to quote in an error message.
// A file can hold anything (binary data, terminal escape sequences, NUL);
// a message shows printable ASCII as is and every other byte as \xNN.
#ifndef EK_SIM_TEXT_ESCAPE_H
#define EK_SIM_TEXT_ESCAPE_H

#include <stddef.h>
#include <stdio.h>

// At most max_in bytes of `in` (stopping at a NUL), "..." appended when
// cut; out (outlen >= 8) is always terminated. quotes != 0 escapes '\' and
// '"' too, for a value shown between quotes (a JSON printout, which has its
// own quotes, is shown with quotes = 0). Returns out.
static inline const char *text_escape(char *out, size_t outlen, const char *in, size_t max_in,
                                      int quotes) {
  size_t o = 0, i = 0;
  for (; in[i] && i < max_in; i++) {
    unsigned char ch = (unsigned char)in[i];
    char piece[8];
    int n;
    if (quotes && (ch == '\\' || ch == '"'))
      n = snprintf(piece, sizeof piece, "\\%c", ch);
    else if (ch >= 0x20 && ch < 0x7f)
      n = snprintf(piece, sizeof piece, "%c", ch);
    else
      n = snprintf(piece, sizeof piece, "\\x%02x", ch);
    if (o + (size_t)n + 4 > outlen) // room for "..." and the terminator
      break;
    for (int k = 0; k < n; k++)
      out[o++] = piece[k];
  }
  if (in[i] && o + 4 <= outlen) {
    out[o++] = '.';
    out[o++] = '.';
    out[o++] = '.';
  }
  out[o] = 0;
  return out;
}

#endif
