#!/usr/bin/env bash
# Copy the working tree (tracked files and new ones that are not git-ignored, as they are
# on disk) to DEST, so an install check builds what a commit would hold, without .venv,
# build/ or egg-info leftovers of the checkout, and without writing into the checkout.
#   usage: scripts/export_tree.sh DEST   (DEST must not exist or be empty)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ "$#" -ne 1 ]; then
  echo "usage: $0 DEST" >&2
  exit 2
fi
DEST="$1"
if [ -e "$DEST" ] && [ -n "$(ls -A "$DEST")" ]; then
  echo "export_tree: $DEST is not empty" >&2
  exit 2
fi
if ! git -C "$ROOT" rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  echo "export_tree: $ROOT is not a git checkout (the file list comes from git)" >&2
  exit 2
fi
mkdir -p "$DEST"
# -c cached (tracked), -o others (untracked) less the ignored ones; files deleted on disk
# but still tracked are skipped (tar would fail on them).
git -C "$ROOT" ls-files -z -c -o --exclude-standard \
  | (cd "$ROOT" && while IFS= read -r -d '' f; do [ -e "$f" ] && printf '%s\0' "$f"; done) \
  | tar -C "$ROOT" --null -T - -cf - \
  | tar -C "$DEST" -xf -
