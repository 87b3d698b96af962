!> Files written whole or not at all: to a temporary name in the same
!> folder, renamed onto the path when complete (a crash or a full disk
!> leaves the old file or none, never half of one).
module mlid_files
  use, intrinsic :: iso_fortran_env, only: int64
  use, intrinsic :: iso_c_binding, only: c_char, c_ptr, c_null_char, c_associated
  use mlid_kinds, only: MLID_OK, MLID_ERR_INPUT
  implicit none
  private
  public :: temporary_for, write_whole, write_file, commit, same_file, not_regular
  public :: file_stamp_t, file_stamp, file_changed

  !> What tells whether a file changed between two looks at it: its size
  !> and modification time (stat(2); whole seconds, what GNU Fortran gives).
  type :: file_stamp_t
    integer(int64) :: size = -1, mtime = -1
  end type file_stamp_t

  interface
    !> The C library's canonical absolute name of an existing file.
    function c_realpath(path, resolved) bind(c, name='realpath') result(p)
      import :: c_char, c_ptr
      character(kind=c_char), intent(in) :: path(*)
      character(kind=c_char), intent(out) :: resolved(*)
      type(c_ptr) :: p
    end function c_realpath
  end interface

contains

  !> A temporary name beside path, and a check that it can be written there
  !> (what: the option that names it, for the message).
  subroutine temporary_for(path, tmp, status, msg, what)
    character(len=*), intent(in) :: path
    character(len=:), allocatable, intent(out) :: tmp
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=*), intent(in), optional :: what
    character(len=16) :: pid
    character(len=:), allocatable :: target
    integer :: unit, slash
    logical :: folder

    inquire (file=path//'/.', exist=folder)
    if (folder) then
      status = MLID_ERR_INPUT
      msg = 'cannot write '//named(path, what)//' (a folder of that name)'
      return
    end if
    ! what is there must be a regular file to replace: a FIFO or a device
    ! became one, and a link that leads nowhere was replaced
    if (len_trim(not_regular(path)) > 0 .or. broken_link(path)) then
      status = MLID_ERR_INPUT
      if (broken_link(path)) then
        msg = 'cannot write '//named(path, what)//' (a link to nothing, or a loop of links)'
      else
        msg = 'cannot write '//named(path, what)//' ('//trim(not_regular(path))// &
              ', not a regular file)'
      end if
      return
    end if
    if (access(trim(path), ' ') == 0 .and. access(trim(path), 'w') /= 0) then
      status = MLID_ERR_INPUT       ! a rename would replace it all the same
      msg = 'cannot write '//named(path, what)//' (a file you may not write)'
      return
    end if
    target = write_target(path)
    write (pid, '(i0)') getpid()
    slash = index(target, '/', back=.true.)
    tmp = target(1:slash)//'.'//target(slash + 1:)//'.tmp-'//trim(pid)
    open (newunit=unit, file=tmp, status='replace', action='write', iostat=status)
    if (status /= 0) then
      status = MLID_ERR_INPUT
      msg = 'cannot write '//named(path, what)//' (its folder is missing or not writable)'
      return
    end if
    close (unit, status='delete')
    status = MLID_OK
    msg = ''
  end subroutine temporary_for

  !> path, after the option that names it if any.
  function named(path, what) result(text)
    character(len=*), intent(in) :: path
    character(len=*), intent(in), optional :: what
    character(len=:), allocatable :: text
    text = path
    if (present(what)) text = what//' '//path
  end function named

  !> Write text to tmp and rename it onto path; on failure nothing is left
  !> behind (tmp deleted, path as it was).
  subroutine write_whole(path, tmp, text, status, msg)
    character(len=*), intent(in) :: path, tmp, text
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: unit, ios
    integer(int64) :: nbytes
    open (newunit=unit, file=tmp, status='replace', action='write', access='stream', &
          form='unformatted', iostat=status)
    if (status /= 0) then
      status = MLID_ERR_INPUT
      msg = 'cannot write '//path
      return
    end if
    write (unit, iostat=status) text
    if (status /= 0) then
      close (unit, status='delete', iostat=ios)
    else
      ! the runtime buffers the text and says nothing when writing it out at
      ! the close fails (a full disk, a file size limit): the size tells
      close (unit, iostat=status)
      if (status == 0) inquire (file=tmp, size=nbytes)
      if (status /= 0 .or. nbytes /= len(text, int64)) then
        status = 1
        call delete(tmp)
      end if
    end if
    if (status /= 0) then
      status = MLID_ERR_INPUT
      msg = 'cannot write '//path//' (the disk is full, a file size limit was reached, or the file went away)'
      return
    end if
    call commit(tmp, path, status, msg)
  end subroutine write_whole

  !> text to path, whole or not at all (a temporary beside it, renamed).
  subroutine write_file(path, text, status, msg)
    character(len=*), intent(in) :: path, text
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=:), allocatable :: tmp
    call temporary_for(trim(path), tmp, status, msg)
    if (status == MLID_OK) call write_whole(trim(path), tmp, text, status, msg)
  end subroutine write_file

  !> Rename tmp onto path; on failure tmp is deleted.
  subroutine commit(tmp, path, status, msg)
    character(len=*), intent(in) :: tmp, path
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    call rename(tmp, write_target(path), status)
    msg = ''
    if (status /= 0) then
      call delete(tmp)
      status = MLID_ERR_INPUT
      msg = 'cannot write '//path//' (a folder of that name, or no permission)'
    end if
  end subroutine commit

  !> Where a write to path goes: the file a link names, so that the link
  !> stays and the file it names is written (a rename onto the link put a
  !> file in its place); path itself otherwise.
  function write_target(path) result(target)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: target
    integer, parameter :: S_IFMT = int(o'170000'), S_IFLNK = int(o'120000')
    integer :: values(13), status
    target = trim(path)
    call lstat(trim(path), values, status)
    if (status /= 0) return
    if (iand(values(3), S_IFMT) /= S_IFLNK) return
    if (len(c_real_path(trim(path))) > 0) target = c_real_path(trim(path))
  end function write_target

  !> Remove the file path if it is there.
  subroutine delete(path)
    character(len=*), intent(in) :: path
    integer :: unit, ios
    open (newunit=unit, file=path, status='old', iostat=ios)
    if (ios == 0) close (unit, status='delete', iostat=ios)
  end subroutine delete

  !> What path is when it is there but no regular file (a link is taken
  !> to what it names): 'a directory', 'a FIFO', 'a device', 'a socket';
  !> '' for a regular file or none.  The readers take regular files only:
  !> a FIFO waits for a writer and a device may never end.
  function not_regular(path) result(what)
    character(len=*), intent(in) :: path
    character(len=16) :: what
    integer, parameter :: S_IFMT = int(o'170000'), S_IFREG = int(o'100000'), &
                          S_IFDIR = int(o'040000'), S_IFIFO = int(o'010000'), &
                          S_IFSOCK = int(o'140000')
    integer :: values(13), status
    what = ''
    call stat(trim(path), values, status)        ! GNU Fortran's stat(2)
    if (status /= 0) return
    select case (iand(values(3), S_IFMT))
    case (S_IFREG)
    case (S_IFDIR)
      what = 'a directory'
    case (S_IFIFO)
      what = 'a FIFO'
    case (S_IFSOCK)
      what = 'a socket'
    case default
      what = 'a device'
    end select
  end function not_regular

  !> Whether path is a symbolic link that leads to no file (a loop, or a
  !> name not there).
  logical function broken_link(path)
    character(len=*), intent(in) :: path
    integer, parameter :: S_IFMT = int(o'170000'), S_IFLNK = int(o'120000')
    integer :: values(13), status
    broken_link = .false.
    call lstat(trim(path), values, status)       ! GNU Fortran's lstat(2)
    if (status /= 0) return
    if (iand(values(3), S_IFMT) /= S_IFLNK) return
    call stat(trim(path), values, status)
    broken_link = status /= 0
  end function broken_link

  !> The stamp of path now (-1s when it cannot be looked at).
  function file_stamp(path) result(stamp)
    character(len=*), intent(in) :: path
    type(file_stamp_t) :: stamp
    integer :: values(13), status
    integer(int64) :: bytes
    call stat(trim(path), values, status)        ! GNU Fortran's stat(2): default kind
    if (status /= 0) return
    inquire (file=trim(path), size=bytes)        ! the size, of any file (over 2 GiB too)
    stamp = file_stamp_t(bytes, int(values(10), int64))
  end function file_stamp

  !> '' when path still has the stamp it had before it was read (before),
  !> else why it is refused: a record rewritten while it was read was read
  !> as a prefix of itself.
  function file_changed(path, before) result(msg)
    character(len=*), intent(in) :: path
    type(file_stamp_t), intent(in) :: before
    character(len=:), allocatable :: msg
    type(file_stamp_t) :: after
    character(len=24) :: a, b
    msg = ''
    after = file_stamp(path)
    if (after%size == before%size .and. after%mtime == before%mtime) return
    write (a, '(i0)') before%size
    write (b, '(i0)') after%size
    msg = 'changed while it was read ('//trim(a)//' bytes when opened, '//trim(b)// &
          ' after, or a new modification time): read it once it is written whole'
  end function file_changed

  !> Whether a and b name one file: by device and inode when both exist
  !> (hard links too), else by the C library's realpath (links, . and ..
  !> resolved; a file not there yet by its folder's).
  logical function same_file(a, b)
    character(len=*), intent(in) :: a, b
    integer :: va(13), vb(13), sa, sb
    same_file = .false.
    if (len_trim(a) == 0 .or. len_trim(b) == 0) return
    call stat(trim(a), va, sa)
    call stat(trim(b), vb, sb)
    if (sa == 0 .and. sb == 0) then      ! (size and time too: GNU stat's 32-bit inode number)
      same_file = all(va([1, 2, 8, 10]) == vb([1, 2, 8, 10]))
    else
      same_file = real_path(a) == real_path(b)
    end if
  end function same_file

  function real_path(path) result(r)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: r
    integer :: k
    r = c_real_path(trim(path))
    if (len(r) > 0) return
    k = index(trim(path), '/', back=.true.)
    if (k == 0) then
      r = c_real_path('.')
    else if (k == 1) then
      r = ''
    else
      r = c_real_path(path(1:k - 1))
    end if
    if (len(r) == 0) then
      r = trim(path)                     ! no such folder: the name as written
    else
      r = r//'/'//trim(path(k + 1:))
    end if
  end function real_path

  !> realpath(path), '' when it fails.
  function c_real_path(path) result(r)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: r
    character(kind=c_char) :: buf(4097)   ! PATH_MAX and its NUL
    integer :: k
    r = ''
    buf = c_null_char
    if (.not. c_associated(c_realpath(path//c_null_char, buf))) return
    do k = 1, size(buf)
      if (buf(k) == c_null_char) exit
      r = r//buf(k)
    end do
  end function c_real_path

end module mlid_files
