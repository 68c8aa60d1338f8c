# Sourced by the real-window tests: start_xvfb WORK_DIR starts Xvfb on a free display (1280x860),
# exports DISPLAY, and kills it and the studio ($studio_pid, once set) when the test exits.
xvfb_pid="" studio_pid=""
cleanup() {
  [[ -n "$studio_pid" ]] && kill "$studio_pid" 2>/dev/null || true
  [[ -n "$xvfb_pid" ]] && kill "$xvfb_pid" 2>/dev/null || true
}
trap cleanup EXIT

start_xvfb() {
  local work=$1 display=""
  # Xvfb picks a free display and writes its number to fd 3.
  Xvfb -displayfd 3 -screen 0 1280x860x24 -nolisten tcp 3>"$work/display" 2>"$work/xvfb.log" &
  xvfb_pid=$!
  for _ in $(seq 100); do
    display=$(head -n1 "$work/display" 2>/dev/null || true)
    [[ "$display" =~ ^[0-9]+$ ]] && break
    sleep 0.1
  done
  [[ "$display" =~ ^[0-9]+$ ]] || { cat "$work/xvfb.log"; echo "Xvfb did not start" >&2; exit 1; }
  export DISPLAY=":$display"
}
