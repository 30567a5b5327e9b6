#!/usr/bin/env bash
# Downloads the models of the built-in scenes sponza, sponza-lanterns, bunnies
# and glossy (which are not in this repository) from their public sources at
# pinned commits, checks each file's SHA-256 against the checksums below, and
# converts the Sponza's Mitsuba scene to OBJ + MTL (scripts/scenes/mitsuba_to_obj.py).
#
#   scripts/fetch-scenes.sh [--from DIR|URL] [DEST]
#
# DEST (default: the first folder penumbra searches that can be written:
# $PENUMBRA_SCENES if set, else <repo>/../shared/scenes) receives
#   sponza/source/{sponza.xml,sponza.serialized}   Mitsuba 0.4 scene, as downloaded
#   sponza/textures/*.JPG, sponza/LICENSE.lajolla_public.txt
#   sponza/sponza.obj, sponza/sponza.mtl            converted from the above
#   models/stanford-bunny.obj
#   sponza/README.md, models/README.md              what these are and where from
# Idempotent: files already there with the pinned checksum are not fetched
# again, and the conversion runs only when its output is missing or a source
# changed. A file whose checksum differs is refused (one line naming it, exit 1).
# --from replaces https://raw.githubusercontent.com: a local folder laid out
# like it (DIR/<owner>/<repo>/<commit>/<path>) or another URL (a mirror).
# When a download fails (offline), it lists what to download by hand and where
# to put it, and exits with status 3. Needs curl or wget, python3, and
# sha256sum or shasum.
set -uo pipefail

prog=fetch-scenes
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/.." && pwd)
canonical=https://raw.githubusercontent.com

lajolla=BachiLi/lajolla_public/7c9dbaa1413c4adbeb20a14e563b880ae7dfc4c9
bunny=alecjacobson/common-3d-test-models/8a4f8642acaf43f9cd7b67858a1502e1055ef202
# source path (under the base URL) | path under DEST | SHA-256
files=(
  "$lajolla/scenes/sponza/sponza.xml|sponza/source/sponza.xml|283bbdb309727f1703c4cb82f30e0d33b5f65fa54b5a5194fb06ef76f1e4cc02"
  "$lajolla/scenes/sponza/sponza.serialized|sponza/source/sponza.serialized|1f038f13bbeb14a058b2191e956f42ca40dca900008fedb2f372d3a5a0426140"
  "$lajolla/scenes/sponza/textures/00_skap.JPG|sponza/textures/00_skap.JPG|73359df247a23b84dcabe478fd241fb0bfde8cbce72945639af01b814e3917ea"
  "$lajolla/scenes/sponza/textures/01_STUB.JPG|sponza/textures/01_STUB.JPG|ed47ff36c2960872ec5076dd0085f3794eeee8374392fc3ce910323e8b43ba96"
  "$lajolla/scenes/sponza/textures/01_S_ba.JPG|sponza/textures/01_S_ba.JPG|cc6b7231e0ab4f589d456b54457baa4e556b007ee0845d8d9967ef549d4db386"
  "$lajolla/scenes/sponza/textures/01_St_kp.JPG|sponza/textures/01_St_kp.JPG|a11e0e90929512ec75271abe051cab3508536d884504f1075db76fb534976c6d"
  "$lajolla/scenes/sponza/textures/KAMEN.JPG|sponza/textures/KAMEN.JPG|e7b304d4aeb756d7c1e8beb2cbf84b13b1a33724df66671722584941e0d72ff7"
  "$lajolla/scenes/sponza/textures/prozor1.JPG|sponza/textures/prozor1.JPG|03e3f4fa5f265958e21f31d2b013e3466d540894c5c33f3ef1526f41fad87be2"
  "$lajolla/scenes/sponza/textures/reljef.JPG|sponza/textures/reljef.JPG|13bb7ccf064ab8bafa57048046124adf800458506c29820152ead5fb0abd8457"
  "$lajolla/scenes/sponza/textures/sp_luk.JPG|sponza/textures/sp_luk.JPG|d1fae3acc77e1f3e031ec0a5704f4e2acce8b5c613c58e13b7b87b655a25bee7"
  "$lajolla/scenes/sponza/textures/vrata_ko.JPG|sponza/textures/vrata_ko.JPG|f83ad40bcf4c46b27d4de90eb450584e17ac51447beb9199ea6a25d49b02c633"
  "$lajolla/scenes/sponza/textures/vrata_kr.JPG|sponza/textures/vrata_kr.JPG|580db253923439d671410cd3b5034174929efcd28171372ba9fd17c4c8f66687"
  "$lajolla/scenes/sponza/textures/x01_st.JPG|sponza/textures/x01_st.JPG|f7091d9b15aa8d01f215cabef7c83b877cad429a0cdc79436a1af22c303508df"
  "$lajolla/LICENSE|sponza/LICENSE.lajolla_public.txt|096febca78dae653666f7f23fa6608f2683fb44a5baf66a11c3f1a8625dd93dd"
  "$bunny/data/stanford-bunny.obj|models/stanford-bunny.obj|1eb35d1e21ce99e5ce911353b6be278990713448dd9e8f5c9387f9de39b32205"
)
sponza_triangles=66445

usage() {
  echo "usage: $0 [--from DIR|URL] [DEST]" >&2
  exit 2
}
say() { echo "$prog: $*"; }
die() {
  echo "$prog: error: $*" >&2
  exit 1
}

base=$canonical
dest=""
while [[ $# -gt 0 ]]; do
  case $1 in
    --from) [[ $# -ge 2 ]] || usage; base=$2; shift 2 ;;
    --from=*) base=${1#--from=}; shift ;;
    -h | --help) sed -n '2,/^set /p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    -*) usage ;;
    *) [[ -z $dest ]] || usage; dest=$1; shift ;;
  esac
done
base=${base%/}

sha256() {
  if command -v sha256sum >/dev/null; then
    sha256sum "$1" | cut -d' ' -f1
  elif command -v shasum >/dev/null; then
    shasum -a 256 "$1" | cut -d' ' -f1
  else
    python3 -c 'import hashlib, sys; print(hashlib.sha256(open(sys.argv[1], "rb").read()).hexdigest())' "$1"
  fi
}

# Every pinned file present in $1 with its checksum, and the conversion's output there.
complete() {
  local e rel sum
  for e in "${files[@]}"; do
    IFS='|' read -r _ rel sum <<<"$e"
    [[ -f $1/$rel && $(sha256 "$1/$rel") == "$sum" ]] || return 1
  done
  [[ -f $1/sponza/sponza.obj && -f $1/sponza/sponza.mtl ]]
}

# Whether folder $1 can be written, or created.
writable() {
  local d=$1
  while [[ ! -e $d ]]; do d=$(dirname "$d"); done
  [[ -d $d && -w $d ]]
}

default_root=$(cd "$repo/.." && pwd)/shared/scenes
if [[ -z $dest ]]; then
  candidates=()
  reason=()
  if [[ -n ${PENUMBRA_SCENES:-} ]]; then
    candidates+=("$PENUMBRA_SCENES")
    reason+=("\$PENUMBRA_SCENES")
  fi
  candidates+=("$default_root")
  reason+=("<repo>/../shared/scenes, where penumbra looks after \$PENUMBRA_SCENES")
  for i in "${!candidates[@]}"; do
    if complete "${candidates[$i]}"; then
      say "${candidates[$i]} (${reason[$i]}) already holds every file, verified; nothing to do"
      exit 0
    fi
    if writable "${candidates[$i]}"; then
      dest=${candidates[$i]}
      say "into $dest (${reason[$i]})"
      break
    fi
  done
  [[ -n $dest ]] || die "none of ${candidates[*]} can be written; pass a folder: $0 DEST (and set PENUMBRA_SCENES to it)"
else
  say "into $dest"
fi
mkdir -p "$dest" || die "cannot create $dest"
dest=$(cd "$dest" && pwd)

# Fetch source path $1 to file $2; on failure print why on stdout and return 1.
fetch() {
  local src=$1 out=$2
  if [[ $base != *://* ]]; then  # a local folder
    if [[ -f $base/$src ]]; then cp "$base/$src" "$out" 2>&1; return; fi
    echo "not in $base"
    return 1
  fi
  if command -v curl >/dev/null; then
    curl -fsSL --connect-timeout 20 --retry 2 -o "$out" "$base/$src" 2>&1 | head -n 1
    return "${PIPESTATUS[0]}"
  elif command -v wget >/dev/null; then
    wget -q -T 20 -t 2 -O "$out" "$base/$src" || { echo "wget failed"; return 1; }
  else
    echo "neither curl nor wget is installed"
    return 1
  fi
}

# Files left to fetch by hand: one line per source folder and destination folder.
by_hand() {
  local e src rel prev_key="" names="" key
  local lines=()
  for e in "$@"; do
    IFS='|' read -r src rel _ <<<"$e"
    if [[ $(basename "$src") == "$(basename "$rel")" ]]; then
      key="$canonical/$(dirname "$src")/ -> $dest/$(dirname "$rel")/"
      if [[ $key == "$prev_key" ]]; then
        names="$names,$(basename "$src")"
        continue
      fi
      [[ -n $prev_key ]] && lines+=("$(flush "$prev_key" "$names")")
      prev_key=$key names=$(basename "$src")
    else
      [[ -n $prev_key ]] && lines+=("$(flush "$prev_key" "$names")")
      prev_key="" names=""
      lines+=("  $canonical/$src -> $dest/$rel")
    fi
  done
  [[ -n $prev_key ]] && lines+=("$(flush "$prev_key" "$names")")
  printf '%s\n' "${lines[@]}"
}
flush() {  # "URLDIR/ -> DESTDIR/" and a,b,c
  local urldir=${1%% -> *} to=${1#* -> }
  if [[ $2 == *,* ]]; then echo "  $urldir{$2} -> $to"; else echo "  $urldir$2 -> $to"; fi
}

changed=0
missing=()
offline_why=""
for e in "${files[@]}"; do
  IFS='|' read -r src rel sum <<<"$e"
  out=$dest/$rel
  if [[ -f $out && $(sha256 "$out") == "$sum" ]]; then
    continue
  fi
  if [[ -n $offline_why ]]; then  # one failure is enough: list the rest without trying them
    missing+=("$e")
    continue
  fi
  [[ -f $out ]] && say "$rel: checksum differs from the pinned one; fetching it again"
  mkdir -p "$(dirname "$out")" || die "cannot create $(dirname "$out")"
  part=$out.part
  if ! failure=$(fetch "$src" "$part"); then
    rm -f "$part"
    offline_why="$base/$src: ${failure:-download failed}"
    missing+=("$e")
    continue
  fi
  got=$(sha256 "$part")
  if [[ $got != "$sum" ]]; then
    rm -f "$part"
    die "$rel: SHA-256 $got from $base/$src is not the pinned $sum: refused, not installed"
  fi
  mv -f "$part" "$out" || die "cannot write $out"
  say "$rel: fetched, SHA-256 verified"
  [[ $rel == sponza/source/* ]] && changed=1
done

if [[ ${#missing[@]} -gt 0 ]]; then
  {
    if [[ $base == *://* ]]; then echo "$prog: cannot download $offline_why (offline?)"; else echo "$prog: cannot copy $offline_why"; fi
    echo "$prog: download these by hand (or pass --from DIR, a copy laid out like $canonical), then run $0 again:"
    by_hand "${missing[@]}"
  } >&2
  exit 3
fi

obj=$dest/sponza/sponza.obj mtl=$dest/sponza/sponza.mtl
if [[ $changed -eq 1 || ! -f $obj || ! -f $mtl ]]; then
  command -v python3 >/dev/null || die "python3 is needed to convert sponza/source/sponza.serialized to sponza.obj"
  tmp=$dest/sponza/.converting
  rm -rf "$tmp" && mkdir -p "$tmp" || die "cannot create $tmp"
  python3 "$here/scenes/mitsuba_to_obj.py" "$dest/sponza/source/sponza.xml" "$tmp/sponza.obj" \
    --header "Dabrovic Sponza (Marko Dabrovic), converted from lajolla_public Mitsuba serialized scene" \
    --mtl-header "Dabrovic Sponza materials (diffuse only), from lajolla_public scenes/sponza/sponza.xml" >/dev/null ||
    { rm -rf "$tmp"; die "converting $dest/sponza/source/sponza.xml failed"; }
  n=$(grep -c '^f ' "$tmp/sponza.obj")
  [[ $n -eq $sponza_triangles ]] ||
    { rm -rf "$tmp"; die "sponza.obj from the conversion has $n triangles, not $sponza_triangles"; }
  mv -f "$tmp/sponza.mtl" "$mtl" && mv -f "$tmp/sponza.obj" "$obj" || die "cannot write $obj"
  rm -rf "$tmp"
  say "sponza/sponza.obj, sponza/sponza.mtl: converted ($n triangles)"
fi

# What these files are; rewritten when this script's text differs from theirs.
write_if_changed() {
  local f=$1 text
  text=$(cat)
  [[ -f $f && $(cat "$f") == "$text" ]] && return
  printf '%s\n' "$text" >"$f" || die "cannot write $f"
}
write_if_changed "$dest/sponza/README.md" <<EOF
# Sponza atrium: Dabrovic original (NOT the Crytek/Meinl version)

Fetched and converted by penumbra's scripts/fetch-scenes.sh.

What this is: the original Sponza atrium by Marko Dabrovic (RNA Studio, 2002),
66,445 triangles, 66,350 vertices (per-vertex normals and UVs), 37 objects,
19 diffuse materials, 10 JPEG textures used (11 shipped). Y is up, units are
metres-ish (bounding box x -17.4..17.4, y -0.91..15.65, z -7.80..7.80).

## Files
- \`sponza.obj\` / \`sponza.mtl\`: converted from the Mitsuba scene below by
  scripts/scenes/mitsuba_to_obj.py. One \`o\` block per Mitsuba shape,
  \`usemtl\` = Mitsuba bsdf id, \`f v/vt/vn\`. The per-shape toWorld transform
  (a tiny translation, ~identity) is applied. UVs: Mitsuba stores v with its
  origin at the top of the image; they are written as \`vt u (1-v)\` (OBJ's
  convention, origin bottom-left). Materials are diffuse only (Kd or map_Kd),
  as in the source scene.
- \`textures/*.JPG\`: the original Dabrovic textures (01_St_kp.JPG is shipped
  but not referenced by any material, as in the source).
- \`source/sponza.xml\`, \`source/sponza.serialized\`: the unmodified source
  scene (Mitsuba 0.4 XML + Mitsuba serialized mesh file, zlib-compressed).
  The XML also holds the original camera and a small spherical area light.
- \`LICENSE.lajolla_public.txt\`: the licence file of the repository the data
  came from (MIT, Tzu-Mao Li). It covers that repository; the Sponza model
  itself carries no separate licence file there. The Dabrovic Sponza has been
  freely redistributed for rendering research since 2002 (credit: Marko
  Dabrovic / RNA Studio).

## Provenance
- Repository: github.com/BachiLi/lajolla_public, commit
  7c9dbaa1413c4adbeb20a14e563b880ae7dfc4c9 (2025-01-06), paths
  \`scenes/sponza/{sponza.xml,sponza.serialized,textures/}\` and \`LICENSE\`,
  each checked against the SHA-256 pinned in scripts/fetch-scenes.sh.
EOF
write_if_changed "$dest/models/README.md" <<EOF
# Test models

Fetched by penumbra's scripts/fetch-scenes.sh.

- \`stanford-bunny.obj\`: the Stanford Bunny (Turk & Levoy 1994, Stanford 3D Scanning Repository,
  graphics.stanford.edu/data/3Dscanrep), 69,451 triangles, positions only. Taken from
  github.com/alecjacobson/common-3d-test-models (commit 8a4f8642acaf43f9cd7b67858a1502e1055ef202,
  data/stanford-bunny.obj), checked against the SHA-256 pinned in scripts/fetch-scenes.sh.
  The Stanford repository allows use of its models for research.
EOF
if [[ $dest == "$default_root" || ( -n ${PENUMBRA_SCENES:-} && $dest == "$(cd "$PENUMBRA_SCENES" 2>/dev/null && pwd)" ) ]]; then
  say "done: $dest holds sponza/ and models/, where penumbra looks for them"
else
  say "done: $dest holds sponza/ and models/; point penumbra at it with PENUMBRA_SCENES=$dest"
fi
