!> HDF5 files (.h5, .hdf5, and MATLAB v7.3 .mat, which is HDF5 after a
!> 512-byte header), read as h5py reads them for tests/binary_reference.py:
!> every dataset, visited as h5py's visititems visits them (H5Ovisit by
!> name, native order: alphabetical within a group, a group's members
!> after it), named by its path ('g/x'); those whose path starts with '#'
!> (MATLAB's #refs#) left out.  Numeric ones (integer and float classes)
!> with a value or more are read as doubles (HDF5 converts), with the text
!> of their attributes units (else unit) and columns.
!>
!> Through the HDF5 C library by bind(c) interfaces (no Fortran module
!> files of the library, so no compiler's .mod format matters).  The
!> symbols are those of HDF5 1.10.3 and later (H5Ovisit2: also in 1.12 and
!> 1.14, built with their deprecated symbols, as Debian's are).  The
!> library prints no error stack while a file is read here (put back after):
!> a damaged file gives one message.  Several threads may read files at
!> once: Debian's library is built thread-safe, and every id opened here
!> is closed here.  A cut file is refused when it is opened (HDF5 checks
!> its end); damaged metadata is the library's to find, and 1.10 does not
!> find all: a damaged global heap (variable-length strings) can make it
!> crash or allocate gigabytes, where h5py's newer library reports it.
module mlid_hdf5file
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t, c_size_t, c_char, c_ptr, c_funptr, &
                                         c_null_char, c_null_ptr, c_null_funptr, c_loc, &
                                         c_funloc, c_f_pointer, c_associated, c_double
  use, intrinsic :: iso_fortran_env, only: int64
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: line_t, short_path
  use mlid_named_arrays, only: named_array_t, arrays_put, printable, itoa => count_text
  implicit none
  private
  public :: hdf5file_read

  integer, parameter :: hid_t = c_int64_t, hsize_t = c_int64_t
  integer(hid_t), parameter :: H5P_DEFAULT = 0, H5S_ALL = 0, H5E_DEFAULT = 0
  integer(c_int), parameter :: H5F_ACC_RDONLY = 0, H5_INDEX_NAME = 0, H5_ITER_NATIVE = 2, &
                               H5O_INFO_BASIC = 1, H5I_DATASET = 5, H5T_INTEGER = 0, &
                               H5T_FLOAT = 1, H5T_STRING = 3

  !> The library's native double type (H5T_NATIVE_DOUBLE), set by H5open:
  !> the library's variable, only read here.  gfortran makes this a common
  !> symbol, which the linker resolves to the library's variable only when
  !> it is public (a private one is hidden, and a copy of its own is made).
  integer(hid_t), bind(c, name='H5T_NATIVE_DOUBLE_g'), public, protected :: native_double

  !> An error of HDF5's error stack (H5E_error2_t).
  type, bind(c) :: h5_error_t
    integer(hid_t) :: cls_id, maj_num, min_num
    integer(c_int) :: line
    type(c_ptr) :: func_name, file_name, desc
  end type h5_error_t

  !> The description of the innermost error, as H5Ewalk2 gives it.
  type :: detail_t
    character(len=120) :: desc = ''
  end type detail_t

  !> The objects' paths as H5Ovisit gives them.
  type :: visit_t
    type(line_t), allocatable :: path(:)
    integer :: n = 0
  end type visit_t

  interface
    integer(c_int) function H5open() bind(c, name='H5open')
      import :: c_int
    end function H5open
    integer(c_int) function H5Eget_auto2(stack, func, data) bind(c, name='H5Eget_auto2')
      import :: c_int, hid_t, c_funptr, c_ptr
      integer(hid_t), value, intent(in) :: stack
      type(c_funptr), intent(out) :: func
      type(c_ptr), intent(out) :: data
    end function H5Eget_auto2
    integer(c_int) function H5Ewalk2(stack, direction, func, data) bind(c, name='H5Ewalk2')
      import :: c_int, hid_t, c_funptr, c_ptr
      integer(hid_t), value, intent(in) :: stack
      integer(c_int), value, intent(in) :: direction
      type(c_funptr), value, intent(in) :: func
      type(c_ptr), value, intent(in) :: data
    end function H5Ewalk2
    integer(c_int) function H5Eset_auto2(stack, func, data) bind(c, name='H5Eset_auto2')
      import :: c_int, hid_t, c_funptr, c_ptr
      integer(hid_t), value, intent(in) :: stack
      type(c_funptr), value, intent(in) :: func
      type(c_ptr), value, intent(in) :: data
    end function H5Eset_auto2
    integer(hid_t) function H5Fopen(name, flags, fapl) bind(c, name='H5Fopen')
      import :: hid_t, c_char, c_int
      character(kind=c_char), intent(in) :: name(*)
      integer(c_int), value, intent(in) :: flags
      integer(hid_t), value, intent(in) :: fapl
    end function H5Fopen
    integer(c_int) function H5Ovisit2(obj, idx, order, op, data, fields) bind(c, name='H5Ovisit2')
      import :: c_int, hid_t, c_funptr, c_ptr
      integer(hid_t), value, intent(in) :: obj
      integer(c_int), value, intent(in) :: idx, order, fields
      type(c_funptr), value, intent(in) :: op
      type(c_ptr), value, intent(in) :: data
    end function H5Ovisit2
    integer(hid_t) function H5Oopen(loc, name, lapl) bind(c, name='H5Oopen')
      import :: hid_t, c_char
      integer(hid_t), value, intent(in) :: loc, lapl
      character(kind=c_char), intent(in) :: name(*)
    end function H5Oopen
    integer(c_int) function H5Iget_type(id) bind(c, name='H5Iget_type')
      import :: c_int, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Iget_type
    integer(hid_t) function H5Dget_type(id) bind(c, name='H5Dget_type')
      import :: hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Dget_type
    integer(hid_t) function H5Dget_space(id) bind(c, name='H5Dget_space')
      import :: hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Dget_space
    integer(c_int) function H5Dread(id, mtype, mspace, fspace, xfer, buf) bind(c, name='H5Dread')
      import :: c_int, hid_t, c_double
      integer(hid_t), value, intent(in) :: id, mtype, mspace, fspace, xfer
      real(c_double), intent(inout) :: buf(*)
    end function H5Dread
    integer(c_int) function H5Tget_class(id) bind(c, name='H5Tget_class')
      import :: c_int, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Tget_class
    integer(c_int) function H5Tis_variable_str(id) bind(c, name='H5Tis_variable_str')
      import :: c_int, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Tis_variable_str
    integer(c_size_t) function H5Tget_size(id) bind(c, name='H5Tget_size')
      import :: c_size_t, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Tget_size
    integer(c_int64_t) function H5Sget_simple_extent_npoints(id) &
        bind(c, name='H5Sget_simple_extent_npoints')
      import :: c_int64_t, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Sget_simple_extent_npoints
    integer(c_int) function H5Sget_simple_extent_ndims(id) &
        bind(c, name='H5Sget_simple_extent_ndims')
      import :: c_int, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Sget_simple_extent_ndims
    integer(c_int) function H5Sget_simple_extent_dims(id, dims, maxdims) &
        bind(c, name='H5Sget_simple_extent_dims')
      import :: c_int, hid_t, hsize_t, c_ptr
      integer(hid_t), value, intent(in) :: id
      integer(hsize_t), intent(out) :: dims(*)
      type(c_ptr), value, intent(in) :: maxdims
    end function H5Sget_simple_extent_dims
    integer(c_int) function H5Aexists(obj, name) bind(c, name='H5Aexists')
      import :: c_int, hid_t, c_char
      integer(hid_t), value, intent(in) :: obj
      character(kind=c_char), intent(in) :: name(*)
    end function H5Aexists
    integer(hid_t) function H5Aopen(obj, name, aapl) bind(c, name='H5Aopen')
      import :: hid_t, c_char
      integer(hid_t), value, intent(in) :: obj, aapl
      character(kind=c_char), intent(in) :: name(*)
    end function H5Aopen
    integer(hid_t) function H5Aget_type(id) bind(c, name='H5Aget_type')
      import :: hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Aget_type
    integer(hid_t) function H5Aget_space(id) bind(c, name='H5Aget_space')
      import :: hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Aget_space
    integer(c_int) function H5Aread(id, mtype, buf) bind(c, name='H5Aread')
      import :: c_int, hid_t, c_ptr
      integer(hid_t), value, intent(in) :: id, mtype
      type(c_ptr), value, intent(in) :: buf
    end function H5Aread
    integer(c_int) function H5free_memory(p) bind(c, name='H5free_memory')
      import :: c_int, c_ptr
      type(c_ptr), value, intent(in) :: p
    end function H5free_memory
    integer(c_size_t) function strlen(p) bind(c, name='strlen')
      import :: c_size_t, c_ptr
      type(c_ptr), value, intent(in) :: p
    end function strlen
    ! closers: H5Fclose, H5Oclose, H5Tclose, H5Sclose, H5Aclose
    integer(c_int) function H5Fclose(id) bind(c, name='H5Fclose')
      import :: c_int, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Fclose
    integer(c_int) function H5Oclose(id) bind(c, name='H5Oclose')
      import :: c_int, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Oclose
    integer(c_int) function H5Tclose(id) bind(c, name='H5Tclose')
      import :: c_int, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Tclose
    integer(c_int) function H5Sclose(id) bind(c, name='H5Sclose')
      import :: c_int, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Sclose
    integer(c_int) function H5Aclose(id) bind(c, name='H5Aclose')
      import :: c_int, hid_t
      integer(hid_t), value, intent(in) :: id
    end function H5Aclose
  end interface

contains

  !> The numeric datasets of the HDF5 file path, arrays(1:n) in h5py's
  !> visiting order.
  subroutine hdf5file_read(path, arrays, n, status, msg)
    character(len=*), intent(in) :: path
    type(named_array_t), allocatable, intent(out) :: arrays(:)
    integer, intent(out) :: n
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(c_funptr) :: old_func
    type(c_ptr) :: old_data
    integer(hid_t) :: file
    integer :: rc

    n = 0
    allocate (arrays(0))
    status = MLID_ERR_INPUT
    msg = 'data file '//short_path(path)//': the HDF5 library cannot be started'
    if (H5open() < 0 .or. native_double <= 0) return
    rc = H5Eget_auto2(H5E_DEFAULT, old_func, old_data)
    rc = H5Eset_auto2(H5E_DEFAULT, c_null_funptr, c_null_ptr)
    file = H5Fopen(trim(path)//c_null_char, H5F_ACC_RDONLY, H5P_DEFAULT)
    if (file < 0) then
      msg = 'data file '//short_path(path)//': cannot be opened as HDF5 '// &
            why('damaged, cut short, or locked by a writer')
    else
      call read_all(file, 'data file '//short_path(path), arrays, n, status, msg)
      if (H5Fclose(file) < 0 .and. status == MLID_OK) then
        status = MLID_ERR_INPUT
        msg = 'data file '//short_path(path)//': cannot be closed as HDF5'
      end if
    end if
    rc = H5Eset_auto2(H5E_DEFAULT, old_func, old_data)
  end subroutine hdf5file_read

  !> Every numeric dataset of file, in h5py's order, into arrays(1:n).
  subroutine read_all(file, where, arrays, n, status, msg)
    integer(hid_t), intent(in) :: file
    character(len=*), intent(in) :: where
    type(named_array_t), allocatable, intent(inout) :: arrays(:)
    integer, intent(inout) :: n
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(visit_t), target :: seen
    type(named_array_t) :: item
    integer(hid_t) :: obj
    logical :: numeric
    integer :: k

    status = MLID_ERR_INPUT
    allocate (seen%path(16))
    if (H5Ovisit2(file, H5_INDEX_NAME, H5_ITER_NATIVE, c_funloc(visited), c_loc(seen), &
                  H5O_INFO_BASIC) < 0) then
      msg = where//': its groups cannot be read as HDF5 '//why('damaged or cut short')
      return
    end if
    do k = 1, seen%n
      associate (p => seen%path(k)%s)
        if (p == '.' .or. p(1:min(1, len(p))) == '#') cycle   ! the root; MATLAB's #refs#
        obj = H5Oopen(file, p//c_null_char, H5P_DEFAULT)
        if (obj < 0) then
          msg = where//': object '//printable(p)//' cannot be opened '// &
                why('damaged or cut short')
          return
        end if
        numeric = .false.
        status = MLID_OK
        if (H5Iget_type(obj) == H5I_DATASET) then
          call read_dataset(obj, where//': dataset '//printable(p), item, numeric, status, msg)
        end if
        if (H5Oclose(obj) < 0 .and. status == MLID_OK) then
          status = MLID_ERR_INPUT
          msg = where//': object '//printable(p)//' cannot be closed'
        end if
        if (status /= MLID_OK) return
        if (numeric) then
          item%name = p
          call arrays_put(arrays, n, item, status, msg)
          if (status /= MLID_OK) return
        end if
      end associate
    end do
    status = MLID_OK
    msg = ''
  end subroutine read_all

  !> H5Ovisit's operator: keep the path of each object (data: a visit_t).
  integer(c_int) function visited(obj, name, info, data) bind(c, name='mlid_hdf5_visited')
    integer(hid_t), value, intent(in) :: obj
    type(c_ptr), value, intent(in) :: name, info, data
    type(visit_t), pointer :: seen
    type(line_t), allocatable :: more(:)
    integer :: k, st

    visited = -1                       ! stops the visit: H5Ovisit2 fails
    call c_f_pointer(data, seen)
    if (seen%n == size(seen%path)) then
      allocate (more(2*seen%n), stat=st)
      if (st /= 0) return
      do k = 1, seen%n
        call move_alloc(seen%path(k)%s, more(k)%s)
      end do
      call move_alloc(more, seen%path)
    end if
    seen%n = seen%n + 1
    seen%path(seen%n)%s = c_text(name)
    visited = 0
  end function visited

  !> '(what went wrong)': the innermost error of the call that failed just
  !> before (the next call clears them), else '(otherwise)'.
  function why(otherwise) result(text)
    character(len=*), intent(in) :: otherwise
    character(len=:), allocatable :: text
    type(detail_t), target :: detail
    integer(c_int), parameter :: H5E_WALK_UPWARD = 0      ! the innermost first
    if (H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, c_funloc(innermost), c_loc(detail)) < 0) &
      detail%desc = ''
    text = '('//trim(printable(detail%desc))//')'
    if (len_trim(detail%desc) == 0) text = '('//otherwise//')'
  end function why

  !> H5Ewalk2's operator: keep the description of error 0 (data: a detail_t).
  integer(c_int) function innermost(n, err, data) bind(c, name='mlid_hdf5_innermost')
    integer(c_int), value, intent(in) :: n
    type(h5_error_t), intent(in) :: err
    type(c_ptr), value, intent(in) :: data
    type(detail_t), pointer :: detail
    call c_f_pointer(data, detail)
    if (n == 0) detail%desc = c_text(err%desc)
    innermost = 0
  end function innermost

  !> The NUL-ended C string at p.
  function c_text(p) result(text)
    type(c_ptr), intent(in) :: p
    character(len=:), allocatable :: text
    character(kind=c_char), pointer :: chars(:)
    integer :: k
    if (.not. c_associated(p)) then
      text = ''
      return
    end if
    call c_f_pointer(p, chars, [strlen(p)])
    allocate (character(len=size(chars)) :: text)
    do k = 1, size(chars)
      text(k:k) = chars(k)
    end do
  end function c_text

  !> Dataset d, when numeric with a value or more: its shape, its values as
  !> doubles (column-major over the shape) and its attributes' text.
  subroutine read_dataset(d, where, item, numeric, status, msg)
    integer(hid_t), intent(in) :: d
    character(len=*), intent(in) :: where
    type(named_array_t), intent(out) :: item
    logical, intent(out) :: numeric
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer(hid_t) :: ftype, space
    integer(hsize_t) :: dims(32)
    integer(int64) :: np
    integer :: cls, nd, rc, st

    numeric = .false.
    status = MLID_ERR_INPUT
    msg = where//': cannot be read (damaged or cut short)'
    ftype = H5Dget_type(d)
    if (ftype < 0) return
    cls = H5Tget_class(ftype)
    rc = H5Tclose(ftype)
    if (cls < 0) return
    status = MLID_OK
    msg = ''
    if (cls /= H5T_INTEGER .and. cls /= H5T_FLOAT) return     ! not numbers: left out
    status = MLID_ERR_INPUT
    msg = where//': cannot be read (damaged or cut short)'
    space = H5Dget_space(d)
    if (space < 0) return
    np = H5Sget_simple_extent_npoints(space)
    nd = H5Sget_simple_extent_ndims(space)
    if (nd >= 0 .and. nd <= size(dims)) rc = H5Sget_simple_extent_dims(space, dims, c_null_ptr)
    if (H5Sclose(space) < 0 .or. np < 0 .or. nd < 0 .or. nd > size(dims)) return
    if (np == 0) then
      status = MLID_OK
      msg = ''
      return
    end if
    allocate (item%v(np), stat=st)
    if (st /= 0) then
      msg = where//': cannot hold its '//itoa(np)//' values'
      return
    end if
    if (H5Dread(d, native_double, H5S_ALL, H5S_ALL, H5P_DEFAULT, item%v) < 0) then
      msg = where//': cannot be read '//why('damaged or cut short')
      return
    end if
    item%shape = dims(1:nd)
    if (nd == 2) item%v = reshape(transpose(reshape(item%v, [dims(2), dims(1)])), [np])
    call read_attributes(d, where, item, status, msg)
    numeric = status == MLID_OK
  end subroutine read_dataset

  !> item's units (the attribute units, else unit; '' for neither) and
  !> columns (left unallocated when there is no such attribute).
  subroutine read_attributes(d, where, item, status, msg)
    integer(hid_t), intent(in) :: d
    character(len=*), intent(in) :: where
    type(named_array_t), intent(inout) :: item
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(line_t), allocatable :: texts(:)
    character(len=5), parameter :: names(2) = ['units', 'unit ']
    integer :: k

    item%units = ''
    do k = 1, 2
      call text_attribute(d, trim(names(k)), where, texts, status, msg)
      if (status /= MLID_OK) return
      if (.not. allocated(texts)) cycle
      if (size(texts) /= 1) then
        status = MLID_ERR_INPUT
        msg = where//': its attribute '//trim(names(k))//' holds '//itoa(size(texts))// &
              ' texts, not one'
        return
      end if
      item%units = texts(1)%s
      exit
    end do
    call text_attribute(d, 'columns', where, item%columns, status, msg)
  end subroutine read_attributes

  !> The texts of attribute name of obj, unallocated when it has none.
  subroutine text_attribute(obj, name, where, texts, status, msg)
    integer(hid_t), intent(in) :: obj
    character(len=*), intent(in) :: name, where
    type(line_t), allocatable, intent(out) :: texts(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer(hid_t) :: attr, atype, space
    integer(int64) :: np
    integer :: rc, there

    status = MLID_ERR_INPUT
    msg = where//': its attribute '//name//' cannot be read'
    there = H5Aexists(obj, name//c_null_char)
    if (there == 0) then
      status = MLID_OK
      msg = ''
      return
    end if
    attr = -1
    if (there > 0) attr = H5Aopen(obj, name//c_null_char, H5P_DEFAULT)
    if (attr < 0) then
      msg = trim(msg)//' '//why('damaged')
      return
    end if
    atype = H5Aget_type(attr)
    space = H5Aget_space(attr)
    np = -1
    if (space >= 0) np = H5Sget_simple_extent_npoints(space)
    if (atype >= 0 .and. np >= 0) then
      if (H5Tget_class(atype) == H5T_STRING) then
        call read_texts(attr, atype, np, texts, status)
        if (status /= MLID_OK) msg = trim(msg)//' '//why('damaged')
      else
        msg = where//': its attribute '//name//' is not text'
      end if
    end if
    if (atype >= 0) rc = H5Tclose(atype)
    if (space >= 0) rc = H5Sclose(space)
    if (H5Aclose(attr) < 0) status = MLID_ERR_INPUT
    if (status == MLID_OK) msg = ''
  end subroutine text_attribute

  !> The np strings of attribute attr of string type atype: variable-length
  !> (h5py's str) or fixed-length (numpy's bytes, trailing NULs dropped as
  !> numpy drops them), read in the file's own string type.
  subroutine read_texts(attr, atype, np, texts, status)
    integer(hid_t), intent(in) :: attr, atype
    integer(int64), intent(in) :: np
    type(line_t), allocatable, intent(out) :: texts(:)
    integer, intent(out) :: status
    type(c_ptr), allocatable, target :: ptr(:)
    character(kind=c_char), allocatable, target :: buf(:)
    integer(int64) :: k, j, size1
    integer :: rc, st

    status = MLID_ERR_INPUT
    allocate (texts(np), stat=st)
    if (st /= 0) return
    if (H5Tis_variable_str(atype) > 0) then
      allocate (ptr(max(np, 1_int64)), stat=st)
      if (st /= 0) return
      ptr = c_null_ptr
      if (H5Aread(attr, atype, c_loc(ptr)) < 0) return
      do k = 1, np
        texts(k)%s = c_text(ptr(k))
        if (c_associated(ptr(k))) rc = H5free_memory(ptr(k))
      end do
    else
      size1 = H5Tget_size(atype)
      allocate (buf(max(np*size1, 1_int64)), stat=st)
      if (st /= 0 .or. size1 <= 0) return
      if (H5Aread(attr, atype, c_loc(buf)) < 0) return
      do k = 1, np
        j = size1
        do while (j > 0)
          if (buf((k - 1)*size1 + j) /= c_null_char) exit
          j = j - 1
        end do
        allocate (character(len=j) :: texts(k)%s)
        do st = 1, int(j)
          texts(k)%s(st:st) = buf((k - 1)*size1 + st)
        end do
      end do
    end if
    status = MLID_OK
  end subroutine read_texts

end module mlid_hdf5file
