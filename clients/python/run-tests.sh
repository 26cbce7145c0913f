#!/bin/sh
# Runs the Python client's test suite against the real binaries.
#
#   clients/python/run-tests.sh [pytest args…]
#
# Creates (once) a virtual environment under the workspace's target/
# folder, installs this package into it the way a user does
# (`pip install ./clients/python[shore]`, which pulls iceoryx2==0.10.0 and
# eclipse-zenoh==1.10.2 from PyPI) plus pytest (and mcap, jsonschema and Foxglove's schemas for the MCAP
# test), and runs the tests from outside the source tree so they
# exercise the installed package. AUV_BIN_DIR names the folder of the
# planner, sensor-sim and vehicle-sim binaries (default target/debug; `cargo
# test --test python` sets it to its own profile's folder).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
venv=$target/pyenv
python=${PYTHON:-python3}

if [ ! -x "$venv/bin/python" ]; then
    "$python" -m venv "$venv"
fi
# `python -m pip`, not bin/pip: a venv copied or moved keeps the old path
# in bin/pip's shebang and would install into the old venv.
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check "$here[shore]" pytest mcap==1.6.0 jsonschema
# Foxglove's own JSON Schemas (npm @foxglove/schemas ships them as a JS
# module), exported once as one NAME.json per schema for test_mcap.py.
schemas=$target/foxglove-schemas
if [ ! -f "$schemas/json/SceneUpdate.json" ]; then
    npm install --silent --no-audit --no-fund --prefix "$schemas" @foxglove/schemas@2.1.0 >&2
    (cd "$schemas" && node -e '
        const s = require("./node_modules/@foxglove/schemas/dist/jsonschema");
        const fs = require("fs");
        fs.mkdirSync("json", { recursive: true });
        for (const [name, schema] of Object.entries(s)) fs.writeFileSync("json/" + name + ".json", JSON.stringify(schema));
    ')
fi
export FOXGLOVE_SCHEMAS="$schemas/json"
export AUV_BIN_DIR="${AUV_BIN_DIR:-$target/debug}"
for b in planner sensor-sim vehicle-sim; do
    if [ ! -x "$AUV_BIN_DIR/$b" ]; then
        echo "run-tests.sh: $AUV_BIN_DIR/$b is missing: build it first (cargo build --workspace)" >&2
        exit 2
    fi
done
cd "$target"
exec "$venv/bin/python" -m pytest -p no:cacheprovider --rootdir "$here/tests" "$here/tests" "$@"
