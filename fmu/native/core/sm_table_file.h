/* The table file of a table curve (curve = table, table_file): TableCurve.from_csv of
 * satmotor/machine/table_curve.py reading a CSV of two columns i_mu [A], psi_m [Wb] in C99, with the
 * same messages.  The points it gives are checked and interpolated by the curve (sm_curves.c). */
#ifndef SM_TABLE_FILE_H
#define SM_TABLE_FILE_H

#include <stddef.h>

#include "sm_common.h"

/* Longest line of a table CSV file [bytes]. */
#define SM_TABLE_LINE_MAX 4096

/* The points of the table file at path in file order (UTF-8, a BOM dropped; '#' starts a comment; blank
 * lines skipped; a first line that is not numeric is the header): i_mu[k] [A], psi_m[k] [Wb] and the file
 * line lines[k] of each, *n_points of them; the arrays hold max_points + 1 entries.  SM_CORE_OK, SM_ERR_ARG
 * (a NULL pointer), or SM_ERR_PARAM with the ParameterError text in msg: the file unreadable or not UTF-8,
 * a line not two numbers, a line longer than SM_TABLE_LINE_MAX, no point, more than max_points. */
int sm_table_file_read(const char *path, int max_points, double *i_mu, double *psi_m, int *lines, int *n_points,
                       char *msg, size_t msg_len);

#endif
