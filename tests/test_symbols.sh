#!/usr/bin/env bash
# The shared library exports exactly the public API: every function the header marks SM_API is
# defined in the dynamic symbol table, and nothing else is (internal functions stay hidden). The
# lock variables that clang's OpenMP emits for reductions (.gomp_critical_user_*) are not API.
#   tests/test_symbols.sh LIBSANDMPM.so sandmpm.h [sandmpm_mpi.h]
set -euo pipefail
lib=$1
shift
headers=("$@")
exported=$(nm -D --defined-only "$lib" | awk '$2 ~ /^[TDBRVW]$/ { print $3 }' |
    grep -v -E '^(_init|_fini|_edata|_end|__bss_start)$' | grep -v -E '^\.gomp_critical_user_' | sort -u)
declared=$(grep -h -E '^SM_API ' "${headers[@]}" | sed -E 's/\(.*//; s/.*[ *]//' | sort -u)
nexp=$(echo "$exported" | grep -c . || true)
ndecl=$(echo "$declared" | grep -c . || true)
missing=$(comm -13 <(echo "$exported") <(echo "$declared"))
extra=$(comm -23 <(echo "$exported") <(echo "$declared"))
status=0
if [ -n "$missing" ]; then
    echo "declared SM_API but not exported:" $missing
    status=1
fi
if [ -n "$extra" ]; then
    echo "exported but not in the public header:" $extra
    status=1
fi
if [ "$ndecl" -lt 40 ]; then
    echo "only $ndecl SM_API declarations found in ${headers[*]}: the pattern is broken"
    status=1
fi
echo "test_symbols: $nexp exported, $ndecl declared"
exit $status
