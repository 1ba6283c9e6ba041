#include "workbench/pipelines/export_rosbag.h"

#include <vector>

#include "core/util/error.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "workbench/formats/ros2_bag.h"

namespace furn {

int ExportRosbag(const std::string& db_path,
                 const std::string& out_bag,
                 const std::string& split,
                 Ros2Storage storage) {
  const Split selected = ParseSplit(split, "--split");
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadOnly);
  std::vector<int64_t> rooms;
  size_t frames_total = 0;
  for (int64_t room_id : dataset.RoomIds()) {
    const RoomRecord room = dataset.ReadRoom(room_id, /*with_images=*/false);
    if (!InSplit(room.split, selected)) continue;
    rooms.push_back(room_id);
    frames_total += room.frames.size();
  }
  Require(frames_total > 0,
          db_path + ": no frames in split '" + std::string(EnumName(selected)) + "'");
  Progress progress("export", frames_total, "frames");
  const std::unique_ptr<FrameBagSink> writer = OpenFrameBag(out_bag, storage);
  for (int64_t room_id : rooms) {
    const RoomRecord room = dataset.ReadRoom(room_id, /*with_images=*/true);
    for (const FrameRecord& frame : room.frames) {
      writer->Write(room, frame, db_path + " frame " + std::to_string(frame.id));
      progress.Advance();
    }
  }
  const int written = writer->Finish();
  progress.Finish();
  return written;
}

}  // namespace furn
