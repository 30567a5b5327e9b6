#!/usr/bin/env bash
# The project's rule: tunables are typed options passed down from the applications (CLI flags, scene fields,
# Python arguments); code below src/apps never reads the environment (src/apps/environment.h reads what the
# applications need, once). Fails, listing them, where a file under src/ outside src/apps calls getenv (or
# secure_getenv, or reads environ).
#   tests/apps/no_getenv_below_apps.sh SRC_DIR
set -uo pipefail
src=${1:?usage: no_getenv_below_apps.sh SRC_DIR}
[[ -d $src/apps ]] || { echo "no_getenv_below_apps.sh: $src is not penumbra's src/ (no apps/ in it)"; exit 1; }
hits=$(grep -rnE '\b(secure_)?getenv\b|\benviron\b' "$src" \
         --include='*.h' --include='*.hpp' --include='*.cpp' --include='*.cu' --include='*.cuh' --include='*.inl' |
       grep -v "^$src/apps/")
if [[ -n $hits ]]; then
  echo "FAIL: code below src/apps reads the environment (pass the value down from src/apps instead):"
  echo "$hits"
  exit 1
fi
echo "PASS: no file under $src outside $src/apps reads the environment"
