// Linked into every fuzz target: LeakSanitizer suppressions for leaks that are not ours.
//
// OpenImageIO 2.4 (Debian 12) keeps each ImageInput's error messages in a thread_local map
// keyed by a per-instance id and never erases an entry when the ImageInput is destroyed (its
// destructor has the erase commented out; fixed upstream in OpenImageIO PR #5276). Every
// corrupt image therefore leaks a few bytes inside OpenImageIO, which libFuzzer reports
// after the first corrupt input; this hides those and only those.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:OpenImageIO_v2_4::ImageInput::geterror\n"
         "leak:OpenImageIO_v2_4::ImageInput::append_error\n";
}
