#pragma once
// Which code made a run (summary.json, run.log, snapshots): the release and the git commit of
// the build's source tree ("-dirty" when it had uncommitted changes). Written at build time.
namespace cassini {

const char* version();
const char* commit();

}  // namespace cassini
