#!/bin/sh
# Every skip in the tests goes through the skip policy (tests/skip_policy.hpp, tests/skip_policy.sh),
# which says whether it needs hardware or an installed package: no bare GTEST_SKIP in a test source, no
# bare exit 77 in a test script. Prints the offending lines and exits 1 if there is any.
# Usage: check_skip_sites.sh SOURCE_DIR
cd "${1:?usage: check_skip_sites.sh SOURCE_DIR}/tests" || exit 2
bad=$(grep -rn --include='*.cpp' --include='*.hpp' 'GTEST_SKIP' . | grep -v '^\./skip_policy\.hpp:'
      grep -rnE --include='*.sh' 'exit 77' . | grep -v -e '^\./skip_policy\.sh:' -e '^\./check_skip_sites\.sh:')
if [ -n "$bad" ]; then
  echo "check_skip_sites: skips that bypass tests/skip_policy.hpp / skip_policy.sh:"
  echo "$bad"
  exit 1
fi
echo "check_skip_sites: every skip goes through the skip policy"
