# Sourced by the scripts that read real data: use ../shared/datasets beside the checkout
# unless CSW_DATA_DIR already names a data folder.
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ -z "${CSW_DATA_DIR:-}" ] && [ -d "$here/../shared/datasets" ]; then
    export CSW_DATA_DIR="$here/../shared/datasets"
fi
