#!/usr/bin/env bash
# The viewer's window on a virtual display: start `twinray view` under Xvfb, press p
# (save the image), o (orthographic), p again and q, with xdotool; the two saved
# images must differ, the title must say orthographic, and the viewer must exit 0.
#   bash view_smoke_test.sh TWINRAY_EXE SCENE WORK_DIR
set -euo pipefail
exe=$1 scene=$2 work=$3
rm -rf "$work"
mkdir -p "$work"
xvfb_pid="" view_pid=""
cleanup() {
  [ -n "$view_pid" ] && kill "$view_pid" 2>/dev/null || true
  [ -n "$xvfb_pid" ] && kill "$xvfb_pid" 2>/dev/null || true
}
trap cleanup EXIT
fail() {
  echo "view_smoke_test: $*" >&2
  echo "--- viewer's stderr:" >&2
  cat "$work/view.err" >&2 || true
  echo "--- Xvfb's stderr:" >&2
  cat "$work/xvfb.err" >&2 || true
  exit 1
}
wait_for() {  # wait_for SECONDS TEST...
  local deadline=$((SECONDS + $1))
  shift
  until "$@"; do
    [ $SECONDS -lt $deadline ] || return 1
    sleep 0.1
  done
}

# Xvfb picks a free display and writes its number to fd 3. -noreset: by default an X
# server resets when its last client leaves, and a connection made during the reset
# fails. The xdotool calls below come and go while the viewer starts, and SDL then
# found no X display in about one run in four.
Xvfb -displayfd 3 -screen 0 640x480x24 -nolisten tcp -noreset 3>"$work/display" \
  2>"$work/xvfb.err" &
xvfb_pid=$!
wait_for 20 test -s "$work/display" || fail "Xvfb did not start: $(cat "$work/xvfb.err")"
export DISPLAY=":$(head -n1 "$work/display")"
# The server answers a client before the viewer starts.
wait_for 20 xdotool getdisplaygeometry >/dev/null 2>&1 ||
  fail "Xvfb on $DISPLAY does not answer: $(cat "$work/xvfb.err")"

# Software drawing: SDL then keeps the X window it first made (with OpenGL it may
# replace it once, which would leave a stale window id here).
export SDL_RENDER_DRIVER=software
"$exe" view "$scene" --width 160 --height 120 --backend cpu --screenshots "$work" \
  2>"$work/view.err" &
view_pid=$!
# The window once it shows a rendered image (SDL may replace its first X window when
# it sets up drawing, so an early id can go stale).
shown() {
  wid=$(xdotool search --onlyvisible --name "twinray view" 2>/dev/null | tail -n1)
  [ -n "$wid" ] || return 1
  local t
  t=$(xdotool getwindowname "$wid" 2>/dev/null) || return 1
  case "$t" in *"| 0.0 ms"*) return 1 ;; esac
}
# A key to the viewer's window, found again each time.
press() {
  local i
  for i in 1 2 3 4 5; do
    if shown && xdotool key --window "$wid" "$1" 2>/dev/null; then return 0; fi
    sleep 0.2
  done
  fail "could not send $1 to the window"
}
title_has() { shown && xdotool getwindowname "$wid" 2>/dev/null | grep -q "$1"; }
wid=""
wait_for 30 shown || fail "no window with a rendered image appeared"

wait_for 10 title_has perspective || fail "title before o: $(xdotool getwindowname "$wid")"
press p
wait_for 30 test -s "$work/twinray-view-001.png" || fail "p saved no image"
press o
wait_for 10 title_has orthographic ||
  fail "title after o: $(xdotool getwindowname "$wid")"
press p
wait_for 30 test -s "$work/twinray-view-002.png" || fail "p after o saved no image"
if cmp -s "$work/twinray-view-001.png" "$work/twinray-view-002.png"; then
  fail "the image did not change after o"
fi
title=$(xdotool getwindowname "$wid")
# (the window may be gone before xdotool returns)
shown && xdotool key --window "$wid" q 2>/dev/null || true
status=0
wait_for 20 sh -c "! kill -0 $view_pid 2>/dev/null" || fail "q did not close the viewer"
wait "$view_pid" || status=$?
view_pid=""
[ "$status" -eq 0 ] || fail "the viewer exited with status $status"
echo "view_smoke_test: ok ($title)"
