#!/usr/bin/env bash
# Checks that the examples of program output in README.md and docs/*.md are what the programs
# print today. Registered as the CTest Docs.Examples (tests/CMakeLists.txt).
#
#   bash tests/docs/check_doc_examples.sh BIN_DIR [SOURCE_DIR] [DOC.md ...]
#
# BIN_DIR holds the programs (build/bin); SOURCE_DIR is the repository (default: two folders
# above this script); with DOC.md files, only those are checked.
#
# An example is marked by an HTML comment just before its block (a fenced block, or one indented
# by four spaces or more; blank lines may come between), naming the commands that print it:
#
#   <!-- output: skylit-sky --calib config/sky_camera.yaml ... -->
#
# or, for several commands, one a line (a heredoc may write a file):
#
#   <!-- output lines=1,-1 mask=[0-9]+[.][0-9]+[[:space:]]s:
#   skylit-bake config/sample_site.yaml -o bake --resolution 40x24 -q
#   skylit-bake verify bake
#   -->
#
# The commands run with bash in a fresh temporary folder that holds links to everything at the
# top of SOURCE_DIR (config/, data/, ...) and build/bin -> BIN_DIR, BIN_DIR first on PATH: a
# command reads as a user types it at the top of the repository, and what it writes stays in the
# temporary folder. Their stdout and stderr together, with the temporary folder's and
# SOURCE_DIR's paths taken out, must equal the block. Keys between "output" and the colon (each
# KEY=VALUE without blanks, not ending in a colon):
#
#   lines=LIST       compare only these lines of the output: N, N-M, and -N counting from the end
#                    (lines=1,-1: the first and the last line); head=N is lines=1-N
#   mask=REGEX       an extended regular expression replaced by # in the output and in the block
#                    alike (timings, and what varies between runs or machines); may be repeated;
#                    [[:space:]] stands for a blank
#   folder=previous  run in the folder of the doc's previous example, with the files it made
#   timeout=S        seconds before the commands are stopped (default 60)
#   slow=1           left out unless SKYLIT_DOC_SLOW=1 (an example that takes more than seconds)
#
# A line of the block that is just "..." stands for any number of output lines (none included);
# trailing blanks are ignored. The programs run on Mesa's software renderer where it is installed,
# so that a machine with a GPU prints what the docs show. On a difference the doc, its line and a
# diff are printed and the check fails; so it does for a marker without a block. SKYLIT_DOC_TIMES=1
# prints each example's time; keep every example to a few seconds.
set -uo pipefail

if (($# < 1)) || [[ "$1" == -h || "$1" == --help ]]; then
  sed -n '2,42p' "$0" | sed 's/^# \{0,1\}//'
  exit $((($# < 1) ? 2 : 0))
fi
bin_dir=$(cd "$1" 2>/dev/null && pwd) || { echo "check_doc_examples: no folder $1 (the build's bin folder)" >&2; exit 2; }
shift
if (($# >= 1)) && [[ -d "$1" ]]; then
  source_dir=$(cd "$1" && pwd)
  shift
else
  source_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
fi
if (($# >= 1)); then
  docs=("$@")
else
  docs=("$source_dir/README.md" "$source_dir"/docs/*.md)
fi

failures=0
examples=0
skipped=0
last_run=""
# A memory-backed folder where there is one: bakes sync every face they write.
tmp_root=${SKYLIT_DOC_TMP:-}
if [[ -z "$tmp_root" ]]; then
  if [[ -d /dev/shm && -w /dev/shm ]]; then tmp_root=/dev/shm; else tmp_root=${TMPDIR:-/tmp}; fi
fi
work=$(mktemp -d "$tmp_root/skylit-doc-examples.XXXXXX")
trap 'rm -rf "$work"' EXIT

# The examples show Mesa's software renderer (llvmpipe): the same output on a machine with a GPU.
mesa_egl=/usr/share/glvnd/egl_vendor.d/50_mesa.json
if [[ -f "$mesa_egl" ]]; then
  export __EGL_VENDOR_LIBRARY_FILENAMES=$mesa_egl LIBGL_ALWAYS_SOFTWARE=1
fi
export LC_ALL=C.UTF-8 TZ=UTC
unset DISPLAY WAYLAND_DISPLAY

# The lines of $1 whose numbers (1-based; negative from the end) $2 lists, comma-separated.
select_lines() {
  local file=$1 list=$2 total
  total=$(wc -l <"$file")
  local IFS=,
  for item in $list; do
    local from to
    if [[ "$item" =~ ^(-?[0-9]+)-(-?[0-9]+)$ ]]; then
      from=${BASH_REMATCH[1]} to=${BASH_REMATCH[2]}
    else
      from=$item to=$item
    fi
    ((from < 0)) && from=$((total + 1 + from))
    ((to < 0)) && to=$((total + 1 + to))
    ((from >= 1 && to >= from)) && sed -n "${from},${to}p" "$file"
  done
}

# Masks and trailing blanks: $1 in, stdout out; the regexes are in the array `masks`.
normalise() {
  local args=()
  for m in "${masks[@]}"; do args+=(-e "s${sep}${m}${sep}#${sep}g"); done
  args+=(-e 's/[[:space:]]+$//')
  sed -E "${args[@]}" "$1"
}

# 0 when the output lines (array `got`) match the block's lines (array `want`), "..." lines being
# any number of lines; else 1, with `bad` the index into `want` where it fails.
match_lines() {
  local i=0 j=0 nw=${#want[@]} ng=${#got[@]}
  while ((i < nw)); do
    if [[ "${want[i]}" =~ ^[[:space:]]*\.\.\.$ ]]; then
      ((i++))
      ((i == nw)) && return 0
      local k=$i
      while ((k < nw)) && ! [[ "${want[k]}" =~ ^[[:space:]]*\.\.\.$ ]]; do ((k++)); done
      local len=$((k - i)) start=-1 s
      if ((k == nw)); then
        s=$((ng - len))
        ((s >= j)) && segment_at "$i" "$s" "$len" && start=$s
      else
        for ((s = j; s + len <= ng; s++)); do
          if segment_at "$i" "$s" "$len"; then start=$s; break; fi
        done
      fi
      ((start < 0)) && { bad=$i; return 1; }
      j=$((start + len))
      i=$k
    else
      ((j < ng)) && [[ "${want[i]}" == "${got[j]}" ]] || { bad=$i; return 1; }
      ((i++, j++))
    fi
  done
  ((j == ng)) || { bad=$nw; return 1; }
  return 0
}
segment_at() {
  local i=$1 s=$2 len=$3 t
  for ((t = 0; t < len; t++)); do [[ "${want[i + t]}" == "${got[s + t]}" ]] || return 1; done
  return 0
}

fail() {
  echo "$doc_name:$1: $2" >&2
  failures=$((failures + 1))
}

check_example() {
  local marker_line=$1 spec=$2 script=$3 block_line=$4 block_file=$5
  examples=$((examples + 1))
  local lines="" timeout_s=60 previous=0 slow=0
  masks=()
  local -a words
  read -ra words <<<"$spec"
  for word in "${words[@]}"; do
    case "$word" in
      lines=*) lines=${word#lines=} ;;
      head=*) lines="1-${word#head=}" ;;
      mask=*) masks+=("${word#mask=}") ;;
      timeout=*) timeout_s=${word#timeout=} ;;
      folder=previous) previous=1 ;;
      slow=1) slow=1 ;;
      *) fail "$marker_line" "unknown key '$word' in the output marker (keys: lines=, head=, mask=, timeout=, folder=previous, slow=1)"; return ;;
    esac
  done
  if ((slow)) && [[ -z "${SKYLIT_DOC_SLOW:-}" ]]; then
    skipped=$((skipped + 1))
    return
  fi
  local run
  if ((previous)); then
    if [[ -z "$last_run" ]]; then
      fail "$marker_line" "folder=previous, but no example before it in this doc"
      return
    fi
    run=$last_run
  else
    [[ -n "$last_run" ]] && rm -rf "$last_run"
    run=$work/run.$examples
    mkdir -p "$run/build"
    for entry in "$source_dir"/* "$source_dir"/.[!.]*; do
      [[ -e "$entry" ]] || continue
      case "${entry##*/}" in build | build-* | .git) continue ;; esac
      ln -s "$entry" "$run/${entry##*/}"
    done
    ln -s "$bin_dir" "$run/build/bin"
    last_run=$run
  fi
  local status=0 started=$EPOCHREALTIME
  (cd "$run" && PATH="$bin_dir:$PATH" timeout "$timeout_s" stdbuf -oL -eL bash -c "$script") \
    >"$work/raw" 2>&1 </dev/null || status=$?
  if [[ -n "${SKYLIT_DOC_TIMES:-}" ]]; then
    local took=$(((${EPOCHREALTIME/./} - ${started/./}) / 1000))
    printf '%s:%s: %d.%03d s\n' "$doc_name" "$marker_line" $((took / 1000)) $((took % 1000)) >&2
  fi
  # Paths of this run read as the user's: relative to the top of the repository.
  sed -e "s${sep}${run}/${sep}${sep}g" -e "s${sep}${run}${sep}.${sep}g" \
      -e "s${sep}${source_dir}/${sep}${sep}g" -e "s${sep}${bin_dir}/${sep}build/bin/${sep}g" \
      -e "s${sep}${bin_dir%/bin}/share/${sep}build/share/${sep}g" "$work/raw" >"$work/out"
  if [[ -n "$lines" ]]; then
    select_lines "$work/out" "$lines" >"$work/selected"
  else
    cp "$work/out" "$work/selected"
  fi
  normalise "$work/selected" >"$work/got"
  normalise "$block_file" >"$work/want"
  mapfile -t got <"$work/got"
  mapfile -t want <"$work/want"
  local bad=0
  if ! match_lines; then
    local where=$((block_line + bad))
    local first_command=${script%%$'\n'*}
    fail "$where" "the example (block at line $block_line) is not what its commands print (exit status $status; first command: $first_command)"
    {
      echo "--- $doc_name:$block_line (the doc)"
      echo "+++ the commands' output${lines:+ (lines $lines)}${masks:+, masked}"
      diff "$work/want" "$work/got" | sed -n '1,40p'
      if ((status != 0)) && ! [[ -s "$work/out" ]]; then echo "(no output)"; fi
    } >&2
  fi
}

sep=$'\x01'  # sed's delimiter: in no path or regex
# <!-- output KEY=VALUE ...: COMMANDS: a value may hold colons but does not end with one, and the
# colon that ends the keys is followed by a blank or the end of the line.
marker_pattern='^[[:space:]]*<!--[[:space:]]*output(([[:space:]]+[a-z]+=[^[:space:]]*[^:[:space:]])*):([[:space:]].*)?$'
for doc in "${docs[@]}"; do
  [[ -f "$doc" ]] || { echo "check_doc_examples: no file $doc" >&2; failures=$((failures + 1)); continue; }
  doc_name=${doc#"$source_dir"/}
  [[ -n "$last_run" ]] && rm -rf "$last_run"
  last_run=""
  mapfile -t text <"$doc"
  n=${#text[@]}
  i=0
  while ((i < n)); do
    line=${text[i]}
    if [[ "$line" =~ $marker_pattern ]]; then
      marker_line=$((i + 1))
      spec=${BASH_REMATCH[1]}
      # A marker indented in a list: its command lines lose the same indentation.
      marker_indent=${line%%<!--*}
      marker_indent=${#marker_indent}
      rest=${BASH_REMATCH[3]}
      script=""
      # The commands: the rest of the line up to -->, or the lines up to the one with -->.
      while :; do
        if [[ "$rest" == *"-->"* ]]; then
          rest=${rest%%-->*}
          script+=$rest
          break
        fi
        script+=$rest$'\n'
        ((i++))
        if ((i >= n)); then fail "$marker_line" "the output marker has no closing -->"; break 2; fi
        rest=${text[i]}
        [[ "${rest:0:marker_indent}" =~ ^[[:space:]]*$ ]] && rest=${rest:marker_indent}
      done
      script=$(sed -e 's/[[:space:]]*$//' <<<"$script" | sed '/^$/d')
      ((i++))
      while ((i < n)) && [[ -z "${text[i]//[[:space:]]/}" ]]; do ((i++)); done
      block=$work/block
      : >"$block"
      if ((i < n)) && [[ "${text[i]}" =~ ^([[:space:]]*)(\`\`\`|~~~) ]]; then
        indent=${#BASH_REMATCH[1]}
        fence=${BASH_REMATCH[2]}
        ((i++))
        block_line=$((i + 1))
        while ((i < n)) && ! [[ "${text[i]}" =~ ^[[:space:]]*${fence}[[:space:]]*$ ]]; do
          printf '%s\n' "${text[i]:indent}" >>"$block"
          ((i++))
        done
        ((i++))
      elif ((i < n)) && [[ "${text[i]}" =~ ^(\ {4,}) ]]; then
        indent=${#BASH_REMATCH[1]}
        block_line=$((i + 1))
        while ((i < n)); do
          if [[ "${text[i]}" =~ ^\ {$indent} ]]; then
            printf '%s\n' "${text[i]:indent}" >>"$block"
          elif [[ -z "${text[i]//[[:space:]]/}" ]] && ((i + 1 < n)) && [[ "${text[i + 1]}" =~ ^\ {$indent} ]]; then
            printf '\n' >>"$block"
          else
            break
          fi
          ((i++))
        done
      else
        fail "$marker_line" "the output marker is not followed by a fenced or indented block"
        continue
      fi
      check_example "$marker_line" "$spec" "$script" "$block_line" "$block"
      continue
    fi
    ((i++))
  done
done

slow_note=""
((skipped > 0)) && slow_note=" ($skipped slow one(s) left out: SKYLIT_DOC_SLOW=1 runs them)"
if ((failures > 0)); then
  echo "check_doc_examples: $failures problem(s) in $examples example(s)$slow_note (see above)" >&2
  exit 1
fi
echo "check_doc_examples: $((examples - skipped)) example(s) match the programs' output$slow_note"
