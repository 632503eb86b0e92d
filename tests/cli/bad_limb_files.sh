#!/usr/bin/env bash
# bad_limb_files.sh SOCKETSMITH DIR: a generated limb (skin and bones, OBJ) spoiled the ways the
# issue-26 fuzzing found, each given to `socketsmith mesh`; every one must end in its own one-line
# error (tests/cli/expect.sh), not in a message about something else:
#   fin:       one triangle stuck on an edge of the skin below its distal end (it read as "not a
#              residual limb" or a size/units mistake) -> exit 4, "non-manifold edge ... fin or sliver"
#   two_skins: the whole limb twice, 15 mm apart (it read as "a bone shell outside the skin")
#              -> exit 1, "the file holds two skins"
set -u
bin=$1; dir=$2
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$dir"; mkdir -p "$dir"
"$bin" limb generate --type transtibial --seed 1 --out "$dir/limb.obj" > /dev/null 2>&1 \
  || { echo "limb generate failed"; exit 1; }
# The fin: a vertex 30 mm below the distal pole (vertex 1) and a triangle on the first face's edge 1-2.
awk '/^v /{n++} {print} END{print "v 0 0 -30"; print "f 2 1 " n+1}' "$dir/limb.obj" > "$dir/fin.obj"
# Two skins: every vertex again shifted 15 mm in x, every face again on the copies.
awk '/^v /{n++; v[n]=$0; print; next} /^f /{f[++m]=$0; print; next}
     END{for(i=1;i<=n;i++){split(v[i],a," "); print "v", a[2]+15, a[3], a[4]}
         for(j=1;j<=m;j++){split(f[j],b," "); print "f", b[2]+n, b[3]+n, b[4]+n}}' "$dir/limb.obj" > "$dir/two_skins.obj"
fail=0
"$here/expect.sh" 4 "the skin has 1 non-manifold edge\(s\) .*a fin or sliver triangle is stuck to the scan" -- \
  "$bin" mesh --limb "$dir/fin.obj" --target-nodes 1000 --out "$dir/fin_out" || { echo "(fin)"; fail=1; }
"$here/expect.sh" 1 "the file holds two skins: a second surface of [0-9]+ cm\^2 \(100 % of the skin's area\)" -- \
  "$bin" mesh --limb "$dir/two_skins.obj" --target-nodes 1000 --out "$dir/two_out" || { echo "(two skins)"; fail=1; }
exit $fail
