# Shared by the benchmarks that run `tandem up` and read its figures (bench/record.sh, view.sh, scale.sh, security.sh).
# Source it.

# cpu_snap PID...: "pid user+system-ticks" for each live PID (from /proc).
cpu_snap() { for p in "$@"; do [ -r "/proc/$p/stat" ] && echo "$p $(awk '{print $14 + $15}' "/proc/$p/stat" 2>/dev/null)"; done; return 0; }

# cpu_cores T0 T1 W0 W1 DIVISOR "PID ...": the cores the PIDs used between two cpu_snap files taken at wall times W0 and
# W1 (seconds), divided by DIVISOR (1, or the module count for a per-module figure).
cpu_cores() {
  local ticks
  ticks=$(awk -v sel="$6" 'NR == FNR {a[$1] = $2; next} ($1 in a) && (sel == "" || index(" " sel " ", " " $1 " ")) {s += $2 - a[$1]} END {print s + 0}' "$1" "$2")
  awk -v d="$ticks" -v hz="$(getconf CLK_TCK)" -v w0="$3" -v w1="$4" -v n="$5" 'BEGIN {printf "%.3f", d / hz / (w1 - w0) / n}'
}

# summary_figures FILE: "late ticks p50 p99 slips" over the modules of a `tandem up --summary FILE` (p50: the mean of
# the modules', p99: the worst); zeros when the file is missing.
summary_figures() {
  awk -F= '
    /^m[0-9]+\.late_commands=/ {late += $2}
    /^m[0-9]+\.ticks=/ {ticks += $2}
    /^m[0-9]+\.latency_p50_us=/ {p50 += $2; c50++}
    /^m[0-9]+\.latency_p99_us=/ {if ($2 > p99) p99 = $2}
    /^m[0-9]+\.slip_events=/ {slips += $2}
    END {printf "%d %d %.0f %.0f %d\n", late, ticks, c50 ? p50 / c50 : 0, p99, slips}' "$1" 2>/dev/null || echo "0 0 0 0 0"
}

# startup_s LOG START: seconds from START (date +%s.%N) to the last module's "first tick at wall T" in a `tandem up` log.
startup_s() {
  (grep -o "first tick at wall [0-9.]*" "$1" || true) | awk -v s="$2" '{v = $5 - s; if (v > m) m = v} END {printf "%.2f", m}'
}

# late_pct LATE TICKS: late arm-ticks in percent of the arm-ticks (two arms per module tick); nan without ticks.
late_pct() { awk -v l="$1" -v t="$2" 'BEGIN {if (t > 0) printf "%.2f", 100 * l / (2 * t); else print "nan"}'; }
