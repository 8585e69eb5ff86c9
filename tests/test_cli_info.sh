# Sourced by tests/test_cli.sh (PART info, CTest test_cli_info): `sandmpm info`'s estimates of a run
# against the run (issue 17 item 5). The disk estimate must match the files the run writes (the
# writers' sizes are known: to 2 %); the step count must lie in info's range; the peak memory must be
# within 15 % of the run's own (getrusage), except under the sanitizers (SANDMPM_TEST_SANITIZED=1:
# their shadow memory is not the program's). No timing is asserted.
scene=$SRC/tests/scenes/info_block.lua
expect 0 "info of the block" "$BIN" info "$scene"
cp "$TMP/out" "$TMP/info"
for k in "probe " "run time " "disk " "memory "; do has "$TMP/info" "$k" "info: the \"$k\" line"; done
disk=$(sed -n 's/^disk .*(\([0-9]*\) bytes;.*/\1/p' "$TMP/info")
mem=$(sed -n 's/^memory *\([0-9.e+]*\) MB at the peak.*/\1/p' "$TMP/info")
range=$(sed -n 's/^run time .*: \([0-9]*\) to \([0-9]*\) steps.*/\1 \2/p; s/^run time .*: \([0-9]*\) steps.*/\1 \1/p' "$TMP/info")
d=$TMP/info_run
expect 0 "run of the block" "$BIN" run "$scene" --out "$d"
written=$(find "$d" -type f -printf '%s\n' | awk '{ s += $1 } END { print s + 0 }')
[ -n "$disk" ] && awk -v a="$disk" -v b="$written" 'BEGIN { exit !(a > 0.98 * b && a < 1.02 * b) }' && ok ||
    bad "info's disk estimate $disk bytes, the run wrote $written bytes"
steps=$(sed -n 's/^sandmpm: done: .*), \([0-9]*\) steps,.*/\1/p' "$TMP/err")
set -- $range
[ -n "$steps" ] && [ $# -eq 2 ] && [ "$1" -le "$steps" ] && [ "$steps" -le "$2" ] && ok ||
    bad "info's steps \"$range\", the run took \"$steps\": $(grep '^run time' "$TMP/info")"
peak=$(sed -n 's/^sandmpm: done: .*peak memory \([0-9.e+]*\) MB;.*/\1/p' "$TMP/err")
if [ "${SANDMPM_TEST_SANITIZED:-0}" != 1 ]; then
    [ -n "$mem" ] && [ -n "$peak" ] && awk -v a="$mem" -v b="$peak" 'BEGIN { exit !(a > 0.85 * b && a < 1.15 * b) }' && ok ||
        bad "info's peak memory $mem MB, the run's $peak MB: $(grep '^memory' "$TMP/info")"
fi
echo "info: disk $disk estimated, $written written; steps $range, ran $steps; memory $mem MB estimated, $peak MB measured"
