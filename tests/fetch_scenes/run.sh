#!/usr/bin/env bash
# scripts/fetch-scenes.sh without the network or the real models (CTest fetch_scenes):
#  - a downloaded file whose SHA-256 is not the pinned one is refused: exit 1, one line
#    on stderr naming it, and nothing left where it would have gone;
#  - offline (a base URL nothing answers) and a local --from folder lacking the files:
#    exit 3 and a few lines saying which canonical URLs to download and where to put them.
#   tests/fetch_scenes/run.sh SCRIPT WORK
set -u
script=$1 work=$2
rm -rf "$work" && mkdir -p "$work" || exit 1
failures=0
check() {  # description, then a command that must succeed
  local what=$1
  shift
  if "$@"; then echo "ok: $what"; else echo "FAIL: $what"; failures=$((failures + 1)); fi
}
lines() { grep -c '' "$1"; }

lajolla=BachiLi/lajolla_public/7c9dbaa1413c4adbeb20a14e563b880ae7dfc4c9
canonical=https://raw.githubusercontent.com

# 1. A corrupted file: the first one the script fetches (sponza.xml) is not the real one.
src=$work/corrupt-src dest=$work/dest
mkdir -p "$src/$lajolla/scenes/sponza"
echo "<scene>not the Sponza</scene>" >"$src/$lajolla/scenes/sponza/sponza.xml"
"$script" --from "$src" "$dest" >"$work/corrupt.out" 2>"$work/corrupt.err"
rc=$?
check "corrupted file: exit status 1 (got $rc)" test "$rc" -eq 1
check "corrupted file: one line on stderr" test "$(lines "$work/corrupt.err")" -eq 1
check "corrupted file: the line names the file and both checksums" grep -Eq \
  "^fetch-scenes: error: sponza/source/sponza.xml: SHA-256 [0-9a-f]{64} from .*/scenes/sponza/sponza.xml is not the pinned 283bbdb309727f1703c4cb82f30e0d33b5f65fa54b5a5194fb06ef76f1e4cc02: refused, not installed$" \
  "$work/corrupt.err"
check "corrupted file: not installed, no partial file" test ! -e "$dest/sponza/source/sponza.xml" -a ! -e "$dest/sponza/source/sponza.xml.part"
check "corrupted file: no conversion" test ! -e "$dest/sponza/sponza.obj"

# 2. Offline: nothing listens on port 1 of this machine.
"$script" --from http://127.0.0.1:1 "$dest" >"$work/offline.out" 2>"$work/offline.err"
rc=$?
check "offline: exit status 3 (got $rc)" test "$rc" -eq 3
check "offline: a few lines (got $(lines "$work/offline.err"))" test "$(lines "$work/offline.err")" -le 8
check "offline: says it cannot download" grep -q "^fetch-scenes: cannot download http://127.0.0.1:1/$lajolla/scenes/sponza/sponza.xml: .*(offline?)$" "$work/offline.err"
check "offline: says to download by hand" grep -q "^fetch-scenes: download these by hand" "$work/offline.err"
check "offline: the Sponza's sources and where they go" grep -qF \
  "  $canonical/$lajolla/scenes/sponza/{sponza.xml,sponza.serialized} -> $dest/sponza/source/" "$work/offline.err"
check "offline: the textures" grep -qF "  $canonical/$lajolla/scenes/sponza/textures/{00_skap.JPG," "$work/offline.err"
check "offline: the licence, renamed" grep -qF "  $canonical/$lajolla/LICENSE -> $dest/sponza/LICENSE.lajolla_public.txt" "$work/offline.err"
check "offline: the bunny" grep -qF \
  "  $canonical/alecjacobson/common-3d-test-models/8a4f8642acaf43f9cd7b67858a1502e1055ef202/data/stanford-bunny.obj -> $dest/models/" \
  "$work/offline.err"

# 3. A local folder without the files: the same list.
mkdir -p "$work/empty-src"
"$script" --from "$work/empty-src" "$dest" >"$work/empty.out" 2>"$work/empty.err"
rc=$?
check "empty --from folder: exit status 3 (got $rc)" test "$rc" -eq 3
check "empty --from folder: names what it lacks" grep -q "^fetch-scenes: cannot copy $work/empty-src/$lajolla/scenes/sponza/sponza.xml: not in $work/empty-src$" "$work/empty.err"
check "empty --from folder: the list" grep -qF "/data/stanford-bunny.obj -> $dest/models/" "$work/empty.err"

# 4. Usage.
"$script" --bogus >/dev/null 2>&1
rc=$?
check "unknown option: exit status 2 (got $rc)" test "$rc" -eq 2

for f in corrupt offline empty; do
  echo "--- $f: stderr"
  cat "$work/$f.err"
done
if [[ $failures -ne 0 ]]; then
  echo "fetch_scenes: $failures checks failed"
  exit 1
fi
echo "fetch_scenes: all checks passed"
