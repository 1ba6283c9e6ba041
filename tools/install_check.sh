#!/usr/bin/env bash
# ctest install/consumer (issue 73): `cmake --install` into a scratch prefix,
# moved elsewhere afterwards (nothing installed may name the first place, the
# build or the source tree), then used as another project would:
#   the workbench finds its data beside itself (no FURN_DATA_DIR, another cwd);
#   a CMake project builds against find_package(furnidet) and detects;
#   a program builds with pkg-config furnidet;
#   python3 imports the installed package and reads furnidet.__version__.
#   tools/install_check.sh BUILD_DIR WORK_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
work=$2
source=$(cd "$(dirname "$0")/.." && pwd)
rm -rf "$work"
mkdir -p "$work"
work=$(cd "$work" && pwd)
fail() { echo "install_check: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$work/first" --strip > "$work/install.log"
mv "$work/first" "$work/prefix"
prefix=$work/prefix
for file in bin/workbench include/furnidet/furnidet.h lib/cmake/furnidet/furnidetConfig.cmake \
    lib/cmake/furnidet/furnidetConfigVersion.cmake lib/pkgconfig/furnidet.pc \
    share/furnidet/data/class_map.json share/furnidet/data/real/labels.json; do
  [[ -e $prefix/$file ]] || fail "missing $file"
done
ls "$prefix"/lib/libfurnidet.so.* > /dev/null || fail "missing lib/libfurnidet.so.*"
if grep -rIl -e "$build" -e "$source" -e "$work/first" "$prefix/lib/cmake" "$prefix/lib/pkgconfig" \
    "$prefix/include"; then
  fail "an installed file names the build, source or first install folder"
fi
version=$(sed -n 's/^project(furnidet VERSION \([0-9.]*\).*/\1/p' "$source/CMakeLists.txt")

# The data beside the moved binary, from another folder.
listing=$(cd / && env -u FURN_DATA_DIR "$prefix/bin/workbench" catalog list --catalog default 2>&1) ||
  fail "workbench catalog list --catalog default: $listing"
grep -q "chair" <<< "$listing" || fail "the installed workbench listed no chair: $listing"
"$prefix/bin/workbench" train --no-vote-net --catalog procedural:4 --vocab kmeans --words 20 \
  --azimuths 8 --quiet --out "$work/model.fcm" > /dev/null

# find_package(furnidet) in a project of one's own.
cmake -S "$source/examples/consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release > "$work/consumer.log" 2>&1 || { cat "$work/consumer.log"; fail "configure"; }
cmake --build "$work/consumer" >> "$work/consumer.log" 2>&1 || { cat "$work/consumer.log"; fail "build"; }
ran=$(cd / && env -u FURN_DATA_DIR "$work/consumer/consumer" "$work/model.fcm")
echo "$ran"
grep -q "^furnidet $version, data in $prefix/share/furnidet/data" <<< "$ran" || fail "consumer: $ran"
grep -q "the camera 1.2[0-9] m above the floor" <<< "$ran" || fail "consumer did not find the floor"

# pkg-config furnidet.
flags=$(PKG_CONFIG_PATH="$prefix/lib/pkgconfig" pkg-config --cflags --libs furnidet)
c++ -std=c++17 "$source/examples/consumer/main.cc" $flags -Wl,-rpath,"$prefix/lib" \
  -o "$work/pkg_consumer"
(cd / && "$work/pkg_consumer") | grep -q "^furnidet $version" || fail "pkg-config build"

# The Python package where Debian's python3 looks (lib/python3.X/dist-packages).
python_dir=$(ls -d "$prefix"/lib/python3*/dist-packages 2> /dev/null | head -1)
if [[ -n $python_dir ]]; then
  got=$(cd / && PYTHONPATH="$python_dir" /usr/bin/python3 -c \
    "import furnidet; print(furnidet.__version__, furnidet.__file__)")
  echo "python: $got"
  [[ $got == "$version $python_dir/furnidet/__init__.py" ]] || fail "python: $got"
fi
echo "install_check: passed ($prefix)"
