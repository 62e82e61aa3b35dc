#include "common/jpeg_strict.h"

#include <csetjmp>
#include <cstdio>  // jpeglib.h needs FILE

#include <jpeglib.h>

namespace loci {
namespace {

struct StrictErrorManager {
  jpeg_error_mgr pub;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {};
  bool warned = false;
};

[[noreturn]] void OnError(j_common_ptr c) {
  auto* e = reinterpret_cast<StrictErrorManager*>(c->err);
  (*c->err->format_message)(c, e->message);
  std::longjmp(e->jump, 1);
}

void OnMessage(j_common_ptr c, int level) {
  auto* e = reinterpret_cast<StrictErrorManager*>(c->err);
  if (level < 0 && !e->warned) {  // level -1: a warning (corrupt data); >= 0: trace output
    e->warned = true;
    (*c->err->format_message)(c, e->message);
  }
}

// Runs the decoder into `out`; false on an error (message in err). No C++ object with a
// destructor lives in this frame, so longjmp out of libjpeg skips nothing.
bool Decompress(jpeg_decompress_struct* cinfo, StrictErrorManager* err, const unsigned char* data,
                unsigned long size, cv::Mat* out) {
  if (setjmp(err->jump)) return false;
  jpeg_create_decompress(cinfo);
  jpeg_mem_src(cinfo, data, size);
  jpeg_read_header(cinfo, TRUE);
  cinfo->out_color_space = JCS_EXT_BGR;
  jpeg_start_decompress(cinfo);
  out->create(static_cast<int>(cinfo->output_height), static_cast<int>(cinfo->output_width),
              CV_8UC3);
  while (cinfo->output_scanline < cinfo->output_height) {
    JSAMPROW row = out->ptr<unsigned char>(static_cast<int>(cinfo->output_scanline));
    jpeg_read_scanlines(cinfo, &row, 1);
  }
  jpeg_finish_decompress(cinfo);
  return !err->warned;
}

}  // namespace

StatusOr<cv::Mat> DecodeJpegStrict(std::string_view bytes) {
  jpeg_decompress_struct cinfo;
  StrictErrorManager err;
  cinfo.err = jpeg_std_error(&err.pub);
  err.pub.error_exit = OnError;
  err.pub.emit_message = OnMessage;
  cv::Mat img;
  const bool ok = Decompress(&cinfo, &err, reinterpret_cast<const unsigned char*>(bytes.data()),
                             static_cast<unsigned long>(bytes.size()), &img);
  jpeg_destroy_decompress(&cinfo);
  if (!ok) return absl::InvalidArgumentError(absl::StrCat("corrupt JPEG: ", err.message));
  return img;
}

}  // namespace loci
