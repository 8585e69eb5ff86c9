#!/bin/sh
# Writes the code between " * @code" and " * @endcode" in the header $1 to $2, without the
# comment's leading " * " (the header's usage example, built as tests/test_header_example).
set -e
{
    echo "/* Extracted from sandmpm.h by cmake/extract_example.sh: edit the header, not this file. */"
    sed -n '/^ \* @code/,/^ \* @endcode/{/^ \* @code/d;/^ \* @endcode/d;s/^ \*//;s/^ //;p;}' "$1"
} >"$2.tmp"
mv "$2.tmp" "$2"
