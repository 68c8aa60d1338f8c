# Sourced by the real-window tests: start_xvfb WORK_DIR starts Xvfb on a free display (1280x860),
# exports DISPLAY, and kills it and the studio ($studio_pid, once set) when the test exits;
# wait_for_script LOG waits for the studio's "script done" line; open_studio starts the studio on a
# scan with a script and waits for it.
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

wait_for_script() {  # LOG: until the studio ($studio_pid) logs "script done" (at most 2 minutes)
  local log=$1
  for _ in $(seq 1200); do
    grep -q "script done" "$log" && return 0
    kill -0 "$studio_pid" 2>/dev/null || { cat "$log"; echo "the studio exited" >&2; exit 1; }
    sleep 0.1
  done
  cat "$log"
  echo "timed out waiting for the studio's script" >&2
  exit 1
}

open_studio() {  # STUDIO SCAN SCRIPT LOG: a 1200x760 window running SCRIPT; sets window, X Y WIDTH HEIGHT
  "$1" "$2" --size 1200x760 --script "$3" >"$4" 2>&1 &
  studio_pid=$!
  wait_for_script "$4"
  window=$(xdotool search --sync --name "PipeRun Studio")
  eval "$(xdotool getwindowgeometry --shell "$window")"
  sleep 1  # The script's last frame.
}
