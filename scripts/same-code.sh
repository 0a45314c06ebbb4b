#!/bin/bash
# Whether two builds of the engine benchmark have the same machine code in the pull and grid
# steps' loops: for a change that should not change what the CPU runs (a refactor), a check that
# no timing on a noisy machine can give (docs/BENCHMARKS.md, "Comparing two engines"; needs
# objdump and perl).
#
#   scripts/same-code.sh BIN_A BIN_B [PATTERN]
#
# Disassembles the functions whose demangled names match PATTERN (an extended regular
# expression; by default the pull and grid steps' group and row loops), with addresses, jump
# targets and symbol hashes taken out, and compares them as multisets of function bodies (the
# linker may order the instances of a generic function differently). Prints how many instances
# each build has, how many are the same, and, for each that is not, its name and instruction count.
set -eu
A=$1; B=$2
PAT=${3:-'engine::(pull|grid)::.*(groups|rows|whole|part|others|long_forces)'}
bodies() {
  # one line per function: the hash of its normalised body, its instruction count, its name
  objdump -d --no-show-raw-insn -C "$1" | perl -MDigest::MD5=md5_hex -ne '
    BEGIN { $pat = qr/$ENV{PAT}/ }
    sub flush { printf "%s\t%d\t%s\n", md5_hex($body), $n, $name if defined $name; undef $name }
    if (/^[0-9a-f]+ <(.*)>:$/) {
      flush();
      my $f = $1;
      if ($f =~ $pat) { ($name, $body, $n) = ($f, "", 0); $name =~ s/::h[0-9a-f]{16}//g }
      next;
    }
    next unless defined $name && /\S/;
    s/^\s*[0-9a-f]+:\s*//; s/0x[0-9a-f]+/X/g; s/\b[0-9a-f]+ </A </g; s/<[^>]*\+X>/<L>/g;
    s/\.llvm\.\d+/.llvm/g; s/anon\.[0-9a-f]+\.\d+/anon/g;
    ($body, $n) = ($body . $_, $n + 1);
    END { flush() }
  ' | sort
}
export PAT
fa=$(mktemp); fb=$(mktemp)
trap 'rm -f "$fa" "$fb"' EXIT
bodies "$A" > "$fa"
bodies "$B" > "$fb"
same=$(comm -12 <(cut -f1 "$fa") <(cut -f1 "$fb") | wc -l)
echo "functions matching: A $(wc -l < "$fa"), B $(wc -l < "$fb"); the same machine code: $same"
for side in A B; do
  x=$fa; y=$fb
  if [ $side = B ]; then x=$fb; y=$fa; fi
  echo "only in $side (instructions, name):"
  comm -23 <(cut -f1 "$x") <(cut -f1 "$y") | grep -F -f - "$x" | cut -f2- | sort -t$'\t' -k2,2 -k1,1n \
    | sed 's/^/  /' || true
done
